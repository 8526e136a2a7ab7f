//===- YaspsInterfaces.td - yasps op interfaces --------------*- tablegen -*-===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSINTERFACES_TD
#define YASPS_DIALECT_YASPS_IR_YASPSINTERFACES_TD

include "mlir/IR/OpBase.td"

def Yasps_DifferentiableOpInterface : OpInterface<"DifferentiableOpInterface"> {
  let cppNamespace = "::mlir::yasps";
  let description = [{
    The derivative rule of a per-instance expression, stated in yasps IR:
    given the tangents (directional derivatives) of the operands, an op emits
    the tangent of its result with yasps ops, at the matrix level (the tangent
    of `det(A)` is `det(A) * trace(inverse(A) * dA)`, of `inverse(A)` is
    `-inverse(A) * dA * inverse(A)`). Second derivatives apply the rules again
    to the emitted ops, which implement this interface too: the op set is
    closed under differentiation (paper section 5, requirement 1).
  }];
  let methods = [
    InterfaceMethod<[{
        Emits, at the builder's insertion point, the tangent of this op's
        result given `operandTangents` (one per operand; a null Value is a
        zero tangent). Returns a null Value when the result's tangent is
        zero, and failure (with a diagnostic) if the op cannot be
        differentiated. Reads, JOINs and UNIONs are the differentiation
        pass's leaves and fail here.
      }],
      "::mlir::FailureOr<::mlir::Value>", "emitTangent",
      (ins "::mlir::OpBuilder &":$builder,
           "::mlir::ArrayRef<::mlir::Value>":$operandTangents)>
  ];
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSINTERFACES_TD
