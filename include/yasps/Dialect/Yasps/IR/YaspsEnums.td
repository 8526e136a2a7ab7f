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

// The enums below are parameters of the dialect's attributes
// (YaspsAttrs.td), not attributes of their own.

def Yasps_ParamKind : I32EnumAttr<"ParamKind",
    "how a group of local parameters is reached from an attribute", [
      I32EnumAttrCase<"read", 0>,
      I32EnumAttrCase<"join", 1>,
      I32EnumAttrCase<"union_", 2, "union">
    ]> {
  let cppNamespace = "::mlir::yasps";
  let genSpecializedAttr = 0;
}

def Yasps_KernelArgKind : I32EnumAttr<"KernelArgKind",
    "what a buffer argument of a generated kernel holds", [
      I32EnumAttrCase<"out", 0>,
      I32EnumAttrCase<"attr", 1>,
      I32EnumAttrCase<"conn", 2>,
      I32EnumAttrCase<"offsets", 3>,
      I32EnumAttrCase<"dof_offsets", 4>
    ]> {
  let cppNamespace = "::mlir::yasps";
  let genSpecializedAttr = 0;
}

def Yasps_DerivativeRole : I32EnumAttr<"DerivativeRole",
    "what a derived attribute holds about its base attribute", [
      I32EnumAttrCase<"jac", 0>,
      I32EnumAttrCase<"grad", 1>,
      I32EnumAttrCase<"hess", 2>,
      I32EnumAttrCase<"hess_proj", 3>,
      I32EnumAttrCase<"hess_inner_proj", 4>,
      I32EnumAttrCase<"ij", 5>,
      I32EnumAttrCase<"dofs", 6>,
      I32EnumAttrCase<"hess_inner", 7>
    ]> {
  let cppNamespace = "::mlir::yasps";
  let genSpecializedAttr = 0;
}

def Yasps_ProjectionKind : I32EnumAttr<"ProjectionKind",
    "how a local Hessian is projected to positive semi-definiteness", [
      I32EnumAttrCase<"full", 0>,
      I32EnumAttrCase<"reduced", 1>,
      I32EnumAttrCase<"separate", 2>
    ]> {
  let cppNamespace = "::mlir::yasps";
  let genSpecializedAttr = 0;
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSENUMS_TD
