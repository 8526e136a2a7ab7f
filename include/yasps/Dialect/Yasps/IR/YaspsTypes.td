//===- YaspsTypes.td - yasps types ---------------------------*- tablegen -*-===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSTYPES_TD
#define YASPS_DIALECT_YASPS_IR_YASPSTYPES_TD

include "yasps/Dialect/Yasps/IR/YaspsDialect.td"
include "mlir/IR/AttrTypeBase.td"
include "mlir/IR/BuiltinTypeInterfaces.td"

def Yasps_MatrixType : TypeDef<Yasps_Dialect, "Matrix"> {
  let mnemonic = "mat";
  let summary = "a per-instance matrix with static shape";
  let description = [{
    The value of an attribute for one instance of its owner: a dense
    `rows x cols` matrix of `f64` or `f32`. Vectors are `3x1` (column) or
    `1x3` (row) matrices and scalars are `1x1`. Stored column-major per
    instance, instances back to back.

    Example: `!yasps.mat<3x1xf64>`, `!yasps.mat<12x12xf32>`.

    At most `kMaxEntries` (16384, e.g. 128x128) entries: kernels keep an
    instance's matrices in registers and on the stack, and the passes
    unroll them entry by entry (a point-triangle Hessian over caged
    vertices, 96x96, is the largest the paper's scenes need).
  }];
  let parameters = (ins "int64_t":$rows, "int64_t":$cols,
                        "::mlir::FloatType":$elementType);
  let hasCustomAssemblyFormat = 1;
  let genVerifyDecl = 1;
  let extraClassDeclaration = [{
    /// The most entries a matrix may have (the verifier's limit).
    static constexpr int64_t kMaxEntries = 16384;
    /// Number of scalars per instance.
    int64_t getNumElements() const { return getRows() * getCols(); }
    bool isSquare() const { return getRows() == getCols(); }
    bool isScalar() const { return getRows() == 1 && getCols() == 1; }
    /// The same element type with another shape.
    MatrixType withShape(int64_t rows, int64_t cols) const {
      return MatrixType::get(getContext(), rows, cols, getElementType());
    }
    /// The 1x1 matrix of the same element type.
    MatrixType getScalarType() const { return withShape(1, 1); }
    /// The 2-D tensor type used for constant values of this shape.
    ::mlir::RankedTensorType getTensorType() const;
  }];
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSTYPES_TD
