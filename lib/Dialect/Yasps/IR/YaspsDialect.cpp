//===- YaspsDialect.cpp - yasps dialect registration ----------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/IR/Builders.h"
#include "mlir/IR/DialectImplementation.h"
#include "llvm/ADT/TypeSwitch.h"

using namespace mlir;
using namespace mlir::yasps;

#include "yasps/Dialect/Yasps/IR/YaspsDialect.cpp.inc"
#include "yasps/Dialect/Yasps/IR/YaspsEnums.cpp.inc"
#include "yasps/Dialect/Yasps/IR/YaspsInterfaces.cpp.inc"

#define GET_TYPEDEF_CLASSES
#include "yasps/Dialect/Yasps/IR/YaspsTypes.cpp.inc"

#define GET_OP_CLASSES
#include "yasps/Dialect/Yasps/IR/YaspsOps.cpp.inc"

void YaspsDialect::initialize() {
  addTypes<
#define GET_TYPEDEF_LIST
#include "yasps/Dialect/Yasps/IR/YaspsTypes.cpp.inc"
      >();
  registerAttributes();
  addOperations<
#define GET_OP_LIST
#include "yasps/Dialect/Yasps/IR/YaspsOps.cpp.inc"
      >();
}

Operation *YaspsDialect::materializeConstant(OpBuilder &builder,
                                             Attribute value, Type type,
                                             Location loc) {
  auto matrixType = dyn_cast<MatrixType>(type);
  auto elements = dyn_cast<DenseFPElementsAttr>(value);
  if (!matrixType || !elements ||
      elements.getType() != matrixType.getTensorType())
    return nullptr;
  return ConstantOp::create(builder, loc, matrixType, elements);
}
