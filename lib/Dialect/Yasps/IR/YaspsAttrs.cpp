//===- YaspsAttrs.cpp - the passes' typed contracts -----------------------===//

#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/IR/DialectImplementation.h"
#include "llvm/ADT/TypeSwitch.h"

using namespace mlir;
using namespace mlir::yasps;

#define GET_ATTRDEF_CLASSES
#include "yasps/Dialect/Yasps/IR/YaspsAttrs.cpp.inc"

void YaspsDialect::registerAttributes() {
  addAttributes<
#define GET_ATTRDEF_LIST
#include "yasps/Dialect/Yasps/IR/YaspsAttrs.cpp.inc"
      >();
}

//===----------------------------------------------------------------------===//
// #yasps.param
//===----------------------------------------------------------------------===//

// read @target | join @conn[slot] of @base, width w | union @attr of @u, width
// w
Attribute ParamAttr::parse(AsmParser &parser, Type) {
  SMLoc loc = parser.getCurrentLocation();
  StringRef keyword;
  if (parser.parseLess() || parser.parseKeyword(&keyword))
    return {};
  std::optional<ParamKind> kind = symbolizeParamKind(keyword);
  if (!kind) {
    parser.emitError(loc, "expected 'read', 'join' or 'union', got '")
        << keyword << "'";
    return {};
  }
  SymbolRefAttr path;
  FlatSymbolRefAttr via;
  int64_t slot = 0, width = 0;
  if (*kind == ParamKind::read) {
    if (parser.parseAttribute(path))
      return {};
  } else {
    if (parser.parseAttribute(via))
      return {};
    if (*kind == ParamKind::join &&
        (parser.parseLSquare() || parser.parseInteger(slot) ||
         parser.parseRSquare()))
      return {};
    if (parser.parseKeyword("of") || parser.parseAttribute(path) ||
        parser.parseComma() || parser.parseKeyword("width") ||
        parser.parseInteger(width))
      return {};
  }
  if (parser.parseGreater())
    return {};
  return getChecked([&] { return parser.emitError(loc); }, parser.getContext(),
                    *kind, path, via, slot, width);
}

void ParamAttr::print(AsmPrinter &printer) const {
  printer << "<" << stringifyParamKind(getKind()) << " ";
  if (getKind() == ParamKind::read) {
    printer << getPath() << ">";
    return;
  }
  printer << getVia();
  if (getKind() == ParamKind::join)
    printer << "[" << getSlot() << "]";
  printer << " of " << getPath() << ", width " << getWidth() << ">";
}

LogicalResult ParamAttr::verify(function_ref<InFlightDiagnostic()> emitError,
                                ParamKind kind, SymbolRefAttr path,
                                FlatSymbolRefAttr via, int64_t slot,
                                int64_t width) {
  if (!path)
    return emitError() << "a parameter needs the path of what it reaches";
  if (kind == ParamKind::read) {
    if (via || slot != 0 || width != 0)
      return emitError() << "a read parameter has no connectivity, slot or "
                            "width";
    return success();
  }
  if (!via)
    return emitError() << "a " << stringifyParamKind(kind)
                       << " parameter needs "
                       << (kind == ParamKind::join ? "its connectivity"
                                                   : "its attribute's name");
  if (width <= 0)
    return emitError() << "a " << stringifyParamKind(kind)
                       << " parameter needs a positive width, got " << width;
  if (slot < 0 || (kind == ParamKind::union_ && slot != 0))
    return emitError() << "invalid slot " << slot << " of a "
                       << stringifyParamKind(kind) << " parameter";
  return success();
}

//===----------------------------------------------------------------------===//
// The discardable attributes the passes agree on
//===----------------------------------------------------------------------===//

/// True if `value` is an array of `Element`s.
template <typename Element> static bool isArrayOf(Attribute value) {
  auto array = dyn_cast<ArrayAttr>(value);
  return array && llvm::all_of(array, llvm::IsaPred<Element>);
}

LogicalResult YaspsDialect::verifyOperationAttribute(Operation *op,
                                                     NamedAttribute attr) {
  StringRef name = attr.getName().getValue();
  Attribute value = attr.getValue();
  StringRef expected;
  if (name == kParamsAttr && !isArrayOf<ParamAttr>(value))
    expected = "an array of #yasps.param";
  else if (name == kKernelArgsAttr && !isArrayOf<KernelArgAttr>(value))
    expected = "an array of #yasps.kernel_arg";
  else if (name == kDerivativeAttr && !isa<DerivativeAttr>(value))
    expected = "a #yasps.derivative";
  else if (name == kProjectionAttr && !isa<ProjectionKindAttr>(value))
    expected = "a #yasps.projection";
  if (expected.empty())
    return success();
  return op->emitError() << "'" << name << "' must be " << expected << ", got "
                         << value;
}
