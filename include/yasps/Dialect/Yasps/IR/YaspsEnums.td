//===- YaspsEnums.td - yasps enumerations --------------------*- tablegen -*-===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSENUMS_TD
#define YASPS_DIALECT_YASPS_IR_YASPSENUMS_TD

include "mlir/IR/EnumAttr.td"

def Yasps_ProjectionMethod : I32EnumAttr<"ProjectionMethod",
    "how a symmetric matrix is made positive semi-definite", [
      I32EnumAttrCase<"clamp", 0>,
      I32EnumAttrCase<"abs", 1>,
      I32EnumAttrCase<"none", 2>
    ]> {
  let cppNamespace = "::mlir::yasps";
}

def Yasps_CmpPredicate : I32EnumAttr<"CmpPredicate",
    "elementwise comparison predicate", [
      I32EnumAttrCase<"lt", 0>,
      I32EnumAttrCase<"le", 1>,
      I32EnumAttrCase<"gt", 2>,
      I32EnumAttrCase<"ge", 3>,
      I32EnumAttrCase<"eq", 4>,
      I32EnumAttrCase<"ne", 5>
    ]> {
  let cppNamespace = "::mlir::yasps";
}

def Yasps_ConcatAxis : I32EnumAttr<"ConcatAxis",
    "direction in which matrices are concatenated", [
      I32EnumAttrCase<"vertical", 0>,
      I32EnumAttrCase<"horizontal", 1>
    ]> {
  let cppNamespace = "::mlir::yasps";
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSENUMS_TD
