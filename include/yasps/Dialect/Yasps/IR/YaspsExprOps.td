//===- YaspsExprOps.td - per-instance matrix expressions -----*- tablegen -*-===//
//
// Expression ops live in the region of a computed attribute (`yasps.attr`).
// Every SSA value is the value of one instance: the region is evaluated for
// each instance of the attribute's owner independently (paper section 4.3).
// Matrix-level ops (det, inverse, matmul, norms, ...) stay matrix-level so
// that differentiation can keep derivatives in closed matrix form.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSEXPROPS_TD
#define YASPS_DIALECT_YASPS_IR_YASPSEXPROPS_TD

include "yasps/Dialect/Yasps/IR/YaspsDialect.td"
include "yasps/Dialect/Yasps/IR/YaspsEnums.td"
include "yasps/Dialect/Yasps/IR/YaspsInterfaces.td"
include "yasps/Dialect/Yasps/IR/YaspsTypes.td"
include "mlir/IR/SymbolInterfaces.td"
include "mlir/Interfaces/InferTypeOpInterface.td"
include "mlir/Interfaces/SideEffectInterfaces.td"

// Operands and results use a plain constraint rather than the TypeDef itself
// so that printed IR spells every type out as `!yasps.mat<...>`.
def Yasps_Mat : Type<CPred<"::llvm::isa<::mlir::yasps::MatrixType>($_self)">,
                     "per-instance matrix">;

class Yasps_ExprOp<string mnemonic, list<Trait> traits = []>
    : Yasps_Op<mnemonic, !listconcat(traits, [Pure, HasParent<"AttrOp">,
        DeclareOpInterfaceMethods<Yasps_DifferentiableOpInterface>])> {
  code exprClassDecl = [{
    /// The per-instance shape of the result.
    ::mlir::yasps::MatrixType getMatrixType() {
      return ::llvm::cast<::mlir::yasps::MatrixType>(getResult().getType());
    }
  }];
  let extraClassDeclaration = exprClassDecl;
}

// The result is the 1x1 matrix of the named operand's element type.
class Yasps_ScalarResultOf<string operand>
    : TypesMatchWith<"result is the 1x1 matrix of the operand's element type",
                     operand, "result",
                     "::llvm::cast<::mlir::yasps::MatrixType>($_self)"
                     ".getScalarType()">;

//===----------------------------------------------------------------------===//
// Reading attributes: own lineage, JOIN, UNION
//===----------------------------------------------------------------------===//

def Yasps_ReadOp : Yasps_ExprOp<"read", [
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "the value of an attribute on the same lineage";
  let description = [{
    Reads the current instance's value of an attribute of the owner, or the
    (broadcast) value of an attribute of the owner's mesh or scene. The path is
    relative to the scene. Reading an attribute of another primitive type is a
    lineage error: use `yasps.join` or `yasps.union`.

    ```mlir
    %x = yasps.read @bunny::@vertices::@position : !yasps.mat<3x1xf64>
    %dt = yasps.read @dt : !yasps.mat<1x1xf64>
    ```
  }];
  let arguments = (ins SymbolRefAttr:$attribute);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$attribute attr-dict `:` type($result)";
}

def Yasps_DofIndexOp : Yasps_ExprOp<"dof_index", [
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "global DoF numbers of a minimisation target's entries";
  let description = [{
    For the current instance `i` of a minimisation target `T` (an attribute
    of `r x c` entries listed in `yasps.minimize`), the `(r*c) x 1` column of
    its entries' global DoF numbers, counted from 1: `offset(T) + i*r*c + e
    + 1` for column-major entry `e`, where `offset(T)` is the first DoF of
    `T` in the layout of the Newton system (targets one after another,
    paper appendix A.1), given to the kernel at run time. Zero is left for
    the padding of UNION slots, so that index attributes built from this
    op (`yasps-generate-indices`) are the 1-based placement indices of
    paper appendix A.3. The path is read like `yasps.read`'s: a target of
    the owner, or of its mesh or scene (instance 0). Indices are exact in
    the float type up to its integer precision (2^53 for f64).

    ```mlir
    %i = yasps.dof_index @bunny::@vertices::@position : !yasps.mat<3x1xf64>
    ```
  }];
  let arguments = (ins SymbolRefAttr:$target);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$target attr-dict `:` type($result)";
}

def Yasps_JoinOp : Yasps_ExprOp<"join", [
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "gathers an attribute through a connectivity (JOIN)";
  let description = [{
    For an owner primitive A with a connectivity `C` of arity `k` to B, and an
    attribute `alpha` of B with per-instance shape `r x c`, the result is the
    `k x (r*c)` matrix whose row `l` is `alpha(C(i)_l)` flattened column-major
    (paper eq. 2). `C` is a connectivity of the owner; `source` is an attribute
    of the connectivity's target.

    ```mlir
    // the four vertex positions of a tet, one per row
    %p = yasps.join @tet2v(@bunny::@vertices::@position) : !yasps.mat<4x3xf64>
    ```
  }];
  let arguments = (ins FlatSymbolRefAttr:$connectivity,
                       SymbolRefAttr:$source);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $connectivity `(` $source `)` attr-dict `:` type($result)
  }];
}

def Yasps_UnionOp : Yasps_ExprOp<"union", [
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "the same-named attribute of every member of a union (UNION)";
  let description = [{
    In an attribute owned by a primitive union, evaluates to the value of the
    attribute `name` of the member that the current instance belongs to
    (paper section 4.6). Every member must have an attribute of that name and
    of the result's shape.

    ```mlir
    %x = yasps.union @position : !yasps.mat<3x1xf64>
    ```
  }];
  let arguments = (ins FlatSymbolRefAttr:$name);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$name attr-dict `:` type($result)";
}

//===----------------------------------------------------------------------===//
// Constants
//===----------------------------------------------------------------------===//

def Yasps_ConstantOp : Yasps_ExprOp<"constant", [
    ConstantLike, DeclareOpInterfaceMethods<InferTypeOpInterface>]> {
  let summary = "a literal matrix (also scalars and zeros)";
  let description = [{
    A constant matrix given as a 2-D dense tensor literal, rows first as
    written. A splat gives a matrix of equal entries, e.g. zeros.

    ```mlir
    %half = yasps.constant dense<0.5> : tensor<1x1xf64>
    %zero = yasps.constant dense<0.0> : tensor<3x3xf64>
    %m = yasps.constant dense<[[1.0, 2.0], [3.0, 4.0]]> : tensor<2x2xf64>
    ```
  }];
  let arguments = (ins ElementsAttr:$value);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$value attr-dict";
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_IdentityOp : Yasps_ExprOp<"identity", [ConstantLike]> {
  let summary = "the identity matrix";
  let description = [{
    ```mlir
    %i = yasps.identity : !yasps.mat<3x3xf64>
    ```
  }];
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "attr-dict `:` type($result)";
  let hasFolder = 1;
  let hasVerifier = 1;
}

//===----------------------------------------------------------------------===//
// Elementwise arithmetic
//===----------------------------------------------------------------------===//

class Yasps_UnaryElementwiseOp<string mnemonic, string what,
                               list<Trait> traits = []>
    : Yasps_ExprOp<mnemonic, !listconcat(traits, [SameOperandsAndResultType])> {
  let summary = what;
  let description = "Applies `" # mnemonic # "` to every entry.\n\n"
      "```mlir\n%r = yasps." # mnemonic # " %x : !yasps.mat<3x1xf64>\n```";
  let arguments = (ins Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$operand attr-dict `:` type($result)";
}

class Yasps_BinaryElementwiseOp<string mnemonic, string what,
                                list<Trait> traits = []>
    : Yasps_ExprOp<mnemonic, !listconcat(traits, [SameOperandsAndResultType])> {
  let summary = what;
  let description = "Entry by entry on two matrices of the same shape.\n\n"
      "```mlir\n%r = yasps." # mnemonic # " %a, %b : !yasps.mat<3x1xf64>\n```";
  let arguments = (ins Yasps_Mat:$lhs, Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$lhs `,` $rhs attr-dict `:` type($result)";
}

def Yasps_AddOp : Yasps_BinaryElementwiseOp<"add", "matrix sum",
                                            [Commutative]> {
  let hasFolder = 1;
}
def Yasps_SubOp : Yasps_BinaryElementwiseOp<"sub", "matrix difference"> {
  let hasFolder = 1;
}
def Yasps_ElementwiseMulOp
    : Yasps_BinaryElementwiseOp<"elementwise_mul",
                                "entrywise (Hadamard) product", [Commutative]> {
  let hasFolder = 1;
}
def Yasps_Atan2Op : Yasps_BinaryElementwiseOp<"atan2",
    "two-argument arctangent atan2(lhs, rhs), entrywise">;
def Yasps_MinOp : Yasps_BinaryElementwiseOp<"min", "entrywise minimum",
                                            [Commutative]>;
def Yasps_MaxOp : Yasps_BinaryElementwiseOp<"max", "entrywise maximum",
                                            [Commutative]>;

def Yasps_NegOp : Yasps_UnaryElementwiseOp<"neg", "negation"> {
  let hasFolder = 1;
}
def Yasps_SqrtOp : Yasps_UnaryElementwiseOp<"sqrt",
    "square root (NaN for negative entries)">;
def Yasps_LogOp : Yasps_UnaryElementwiseOp<"log",
    "natural logarithm (NaN for negative entries, -inf for zero)">;
def Yasps_ExpOp : Yasps_UnaryElementwiseOp<"exp", "exponential">;
def Yasps_SinOp : Yasps_UnaryElementwiseOp<"sin", "sine">;
def Yasps_CosOp : Yasps_UnaryElementwiseOp<"cos", "cosine">;
def Yasps_AbsOp : Yasps_UnaryElementwiseOp<"abs", "absolute value">;

def Yasps_StopGradientOp : Yasps_UnaryElementwiseOp<"stop_gradient",
    "the value, treated as a constant by differentiation"> {
  let description = [{
    Passes its operand through; derivatives with respect to anything flowing
    into it are zero (the paper's `asConstant`).

    ```mlir
    %c = yasps.stop_gradient %x : !yasps.mat<3x1xf64>
    ```
  }];
  let hasFolder = 1;
}

def Yasps_PowOp : Yasps_ExprOp<"pow", [AllTypesMatch<["base", "result"]>]> {
  let summary = "entrywise power";
  let description = [{
    Raises every entry of `base` to the matching entry of `exponent`, or to
    the same power when `exponent` is 1x1.

    ```mlir
    %r = yasps.pow %x, %e : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$base, Yasps_Mat:$exponent);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $base `,` $exponent attr-dict `:` type($base) `,` type($exponent)
  }];
  let hasVerifier = 1;
}

def Yasps_CmpOp : Yasps_ExprOp<"cmp", [SameOperandsAndResultType]> {
  let summary = "entrywise comparison, 1.0 where true and 0.0 where false";
  let description = [{
    ```mlir
    %m = yasps.cmp lt, %d, %dhat : !yasps.mat<1x1xf64>
    ```
  }];
  let arguments = (ins Yasps_CmpPredicate:$predicate, Yasps_Mat:$lhs,
                       Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$predicate `,` $lhs `,` $rhs attr-dict `:` type($result)";
}

def Yasps_SelectOp : Yasps_ExprOp<"select", [
    AllTypesMatch<["true_value", "false_value", "result"]>]> {
  let summary = "chooses entries by a condition";
  let description = [{
    Where the condition is non-zero the result takes `true_value`, elsewhere
    `false_value`. The condition is 1x1 (one choice for the whole matrix) or
    has the values' shape (a choice per entry).

    ```mlir
    %r = yasps.select %c, %a, %b : !yasps.mat<1x1xf64>, !yasps.mat<3x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$condition,
                       Yasps_Mat:$true_value,
                       Yasps_Mat:$false_value);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $condition `,` $true_value `,` $false_value attr-dict `:`
    type($condition) `,` type($result)
  }];
  let hasVerifier = 1;
}

//===----------------------------------------------------------------------===//
// Scalar scaling and matrix algebra
//===----------------------------------------------------------------------===//

def Yasps_ScaleOp : Yasps_ExprOp<"scale", [AllTypesMatch<["lhs", "result"]>]> {
  let summary = "a matrix times a 1x1 scalar";
  let description = [{
    ```mlir
    %r = yasps.scale %m, %s : !yasps.mat<3x3xf64>, !yasps.mat<1x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$lhs, Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$lhs `,` $rhs attr-dict `:` type($lhs) `,` type($rhs)";
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_DivOp : Yasps_ExprOp<"div", [AllTypesMatch<["lhs", "result"]>]> {
  let summary = "a matrix divided by a 1x1 scalar";
  let description = [{
    ```mlir
    %r = yasps.div %m, %s : !yasps.mat<3x3xf64>, !yasps.mat<1x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$lhs, Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$lhs `,` $rhs attr-dict `:` type($lhs) `,` type($rhs)";
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_MatmulOp : Yasps_ExprOp<"matmul"> {
  let summary = "matrix product";
  let description = [{
    ```mlir
    %p = yasps.matmul %a, %r : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64>
                             -> !yasps.mat<3x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$lhs, Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $lhs `,` $rhs attr-dict `:` type($lhs) `,` type($rhs) `->` type($result)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_TransposeOp : Yasps_ExprOp<"transpose"> {
  let summary = "matrix transpose";
  let description = [{
    ```mlir
    %t = yasps.transpose %x : !yasps.mat<3x1xf64> -> !yasps.mat<1x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $operand attr-dict `:` type($operand) `->` type($result)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_DotOp : Yasps_ExprOp<"dot", [AllTypesMatch<["lhs", "rhs"]>,
                                       Yasps_ScalarResultOf<"lhs">]> {
  let summary = "sum of entrywise products of two same-shape matrices";
  let description = [{
    The Frobenius inner product: works on column vectors, row vectors and
    matrices alike. The result is 1x1.

    ```mlir
    %d = yasps.dot %a, %b : !yasps.mat<1x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$lhs, Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$lhs `,` $rhs attr-dict `:` type($lhs)";
}

def Yasps_CrossOp : Yasps_ExprOp<"cross", [SameOperandsAndResultType]> {
  let summary = "cross product of two 3-vectors (3x1 or 1x3)";
  let description = [{
    ```mlir
    %n = yasps.cross %e0, %e1 : !yasps.mat<3x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$lhs, Yasps_Mat:$rhs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$lhs `,` $rhs attr-dict `:` type($result)";
  let hasVerifier = 1;
}

class Yasps_ToScalarOp<string mnemonic, string what, string doc>
    : Yasps_ExprOp<mnemonic, [Yasps_ScalarResultOf<"operand">]> {
  let summary = what;
  let description = doc # "\n\n```mlir\n%r = yasps." # mnemonic #
                    " %m : !yasps.mat<3x3xf64>\n```";
  let arguments = (ins Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$operand attr-dict `:` type($operand)";
}

def Yasps_DetOp : Yasps_ToScalarOp<"det", "determinant of a square matrix",
    "The result is 1x1."> {
  let hasVerifier = 1;
}
def Yasps_TraceOp : Yasps_ToScalarOp<"trace", "trace of a square matrix",
    "The sum of the diagonal; the result is 1x1."> {
  let hasVerifier = 1;
}
def Yasps_SingularValueSumOp : Yasps_ToScalarOp<"singular_value_sum",
    "sum of the signed singular values of a matrix of at most 3x3",
    [{`tr(S)` of the polar decomposition `A = R S` with R a rotation: the sum
    of A's singular values with the smallest one negated where `det A < 0`
    (fixed corotated elasticity's `|F - R|^2 = |F|^2 - 2 tr(S) + 3`). No
    SVD is needed: with `I = |A|^2`, `II = |cof A|^2` and `J = det A`, a 3x3
    result s is the largest root of `(s^2 - I)^2 - 8 J s - 4 II`, whose four
    real roots are the sign patterns of the singular values with an even
    number of flips; kernels find it by Newton's method from an upper
    bound, and derivatives follow by implicit differentiation in terms of
    s itself. A 2x2 result is `sqrt(I + 2 J)`, a 1x1 one the entry. The
    derivative is singular where two signed singular values sum to zero
    (the rotation is not unique there). The result is 1x1.}]> {
  let hasVerifier = 1;
}
def Yasps_NormOp : Yasps_ToScalarOp<"norm", "Frobenius norm",
    "The square root of the sum of squared entries; the result is 1x1.">;
def Yasps_SquaredNormOp : Yasps_ToScalarOp<"squared_norm",
    "squared Frobenius norm",
    "The sum of squared entries; the result is 1x1.">;
def Yasps_SumOp : Yasps_ToScalarOp<"sum", "sum of all entries",
    "The result is 1x1.">;

def Yasps_InverseOp : Yasps_ExprOp<"inverse", [SameOperandsAndResultType]> {
  let summary = "inverse of a square matrix";
  let description = [{
    ```mlir
    %i = yasps.inverse %dm : !yasps.mat<3x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$operand attr-dict `:` type($result)";
  let hasVerifier = 1;
}

def Yasps_CofactorOp : Yasps_ExprOp<"cofactor", [SameOperandsAndResultType]> {
  let summary = "cofactor matrix of a square matrix";
  let description = [{
    The matrix C of signed minors, `C_ij = (-1)^(i+j) M_ij`: the derivative
    of the determinant, `det(A)' = <C, A'>`, and `C = det(A) A^-T` where A
    is invertible. It is polynomial in A (for 3x3 its columns are cross
    products of A's columns), so derivatives of determinants through it
    stay polynomial: the second derivative of a 3x3 determinant is linear
    in the entries, as in hand-derived code.

    ```mlir
    %c = yasps.cofactor %f : !yasps.mat<3x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$operand attr-dict `:` type($result)";
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_ProjectOp : Yasps_ExprOp<"project", [SameOperandsAndResultType]> {
  let summary = "projection of a symmetric matrix to positive semi-definite";
  let description = [{
    Eigen-decomposes a symmetric matrix and rebuilds it with its eigenvalues
    changed by `method`: `clamp` sets negative eigenvalues to zero (the
    default of energies), `abs` takes their absolute value, `none` leaves the
    matrix unchanged (paper section 5.4).

    ```mlir
    %h = yasps.project clamp %hess : !yasps.mat<12x12xf64>
    ```
  }];
  let arguments = (ins Yasps_ProjectionMethod:$method,
                       Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = "$method $operand attr-dict `:` type($result)";
  let hasVerifier = 1;
}

//===----------------------------------------------------------------------===//
// Extracting and rearranging entries
//===----------------------------------------------------------------------===//

def Yasps_RowOp : Yasps_ExprOp<"row"> {
  let summary = "one row of a matrix, as a 1 x cols matrix";
  let description = [{
    ```mlir
    %p0 = yasps.row %p[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$index);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $operand `[` $index `]` attr-dict `:` type($operand) `->` type($result)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_ColOp : Yasps_ExprOp<"col"> {
  let summary = "one column of a matrix, as a rows x 1 matrix";
  let description = [{
    ```mlir
    %c = yasps.col %f[2] : !yasps.mat<3x3xf64> -> !yasps.mat<3x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$index);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $operand `[` $index `]` attr-dict `:` type($operand) `->` type($result)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_ElementOp : Yasps_ExprOp<"element", [
    Yasps_ScalarResultOf<"operand">]> {
  let summary = "one entry of a matrix, as a 1x1 matrix";
  let description = [{
    ```mlir
    %a = yasps.element %m[1, 2] : !yasps.mat<3x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$row,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$col);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $operand `[` $row `,` $col `]` attr-dict `:` type($operand)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_SliceOp : Yasps_ExprOp<"slice"> {
  let summary = "a rectangular block of a matrix";
  let description = [{
    The block whose top-left entry is (`row_offset`, `col_offset`) and whose
    size is the result's shape.

    ```mlir
    %b = yasps.slice %m[0, 1] : !yasps.mat<3x3xf64> -> !yasps.mat<2x2xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$row_offset,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$col_offset);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $operand `[` $row_offset `,` $col_offset `]` attr-dict `:`
    type($operand) `->` type($result)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_ResizeOp : Yasps_ExprOp<"resize"> {
  let summary = "reinterprets the entries under another shape (column-major)";
  let description = [{
    Keeps the column-major sequence of entries and reads it with the result's
    shape, like Eigen's `reshaped()`: a 1x9 row from a JOIN of a 3x3 matrix
    resizes back to that 3x3 matrix.

    ```mlir
    %a = yasps.resize %row : !yasps.mat<1x9xf64> -> !yasps.mat<3x3xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$operand);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $operand attr-dict `:` type($operand) `->` type($result)
  }];
  let hasFolder = 1;
  let hasVerifier = 1;
}

def Yasps_ConcatOp : Yasps_ExprOp<"concat"> {
  let summary = "stacks matrices vertically or side by side";
  let description = [{
    `vertical` stacks operands with equal column counts on top of each other;
    `horizontal` places operands with equal row counts side by side.

    ```mlir
    %x = yasps.concat vertical %a, %b : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>
                                        -> !yasps.mat<6x1xf64>
    ```
  }];
  let arguments = (ins Yasps_ConcatAxis:$axis,
                       Variadic<Yasps_Mat>:$inputs);
  let results = (outs Yasps_Mat:$result);
  let assemblyFormat = [{
    $axis $inputs attr-dict `:` type($inputs) `->` type($result)
  }];
  let hasVerifier = 1;
}

//===----------------------------------------------------------------------===//
// Terminator
//===----------------------------------------------------------------------===//

def Yasps_YieldOp : Yasps_Op<"yield", [Pure, Terminator,
                                       HasParent<"AttrOp">]> {
  let summary = "the per-instance value of a computed attribute";
  let description = [{
    ```mlir
    yasps.yield %e : !yasps.mat<1x1xf64>
    ```
  }];
  let arguments = (ins Yasps_Mat:$value);
  let assemblyFormat = "$value attr-dict `:` type($value)";
  let hasVerifier = 1;
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSEXPROPS_TD
