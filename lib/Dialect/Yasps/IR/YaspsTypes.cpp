//===- YaspsTypes.cpp - the per-instance matrix type ----------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/IR/DialectImplementation.h"

using namespace mlir;
using namespace mlir::yasps;

// Printed as `!yasps.mat<3x1xf64>`, the shape syntax of builtin tensors.
Type MatrixType::parse(AsmParser &parser) {
  SmallVector<int64_t, 2> shape;
  Type elementType;
  SMLoc loc = parser.getCurrentLocation();
  if (parser.parseLess() ||
      parser.parseDimensionList(shape, /*allowDynamic=*/false,
                                /*withTrailingX=*/true) ||
      parser.parseType(elementType) || parser.parseGreater())
    return {};
  if (shape.size() != 2) {
    parser.emitError(loc) << "expected rows x cols, got " << shape.size()
                          << " dimension(s)";
    return {};
  }
  auto floatType = dyn_cast<FloatType>(elementType);
  if (!floatType) {
    parser.emitError(loc) << "expected f32 or f64 element type, got "
                          << elementType;
    return {};
  }
  return parser.getChecked<MatrixType>(loc, parser.getContext(), shape[0],
                                       shape[1], floatType);
}

void MatrixType::print(AsmPrinter &printer) const {
  printer << "<" << getRows() << "x" << getCols() << "x" << getElementType()
          << ">";
}

LogicalResult MatrixType::verify(function_ref<InFlightDiagnostic()> emitError,
                                 int64_t rows, int64_t cols,
                                 FloatType elementType) {
  if (rows < 1 || cols < 1)
    return emitError() << "matrix shape must be at least 1x1, got " << rows
                       << "x" << cols;
  // rows and cols are each at most kMaxEntries here, so the product cannot
  // overflow.
  if (rows > kMaxEntries || cols > kMaxEntries ||
      rows * cols > kMaxEntries)
    return emitError() << "matrix shape " << rows << "x" << cols
                       << " has more than the " << kMaxEntries
                       << " entries a yasps matrix may have";
  if (!elementType.isF32() && !elementType.isF64())
    return emitError() << "matrix element type must be f32 or f64, got "
                       << elementType;
  return success();
}

RankedTensorType MatrixType::getTensorType() const {
  return RankedTensorType::get({getRows(), getCols()}, getElementType());
}
