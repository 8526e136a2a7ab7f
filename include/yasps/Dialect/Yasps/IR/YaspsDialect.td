//===- YaspsDialect.td - the yasps dialect -------------------*- tablegen -*-===//
//
// The yasps dialect: scene structure and per-instance matrix expressions of
// the YASPS paper (section 4, appendix F).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSDIALECT_TD
#define YASPS_DIALECT_YASPS_IR_YASPSDIALECT_TD

include "mlir/IR/OpBase.td"

def Yasps_Dialect : Dialect {
  let name = "yasps";
  let cppNamespace = "::mlir::yasps";
  let summary = "Scenes, primitives and per-instance matrix expressions for "
                "differentiable simulation";
  let description = [{
    The `yasps` dialect describes a simulation scene the way the YASPS paper
    does: a `yasps.scene` holds meshes, a mesh holds primitive types (vertices,
    tetrahedra, affine bodies, collision pairs, ...) and primitive unions, and
    every level can carry named attributes. An attribute is a function from the
    instances of its owner to `r x c` matrices.

    Structure ops are symbols; attributes refer to each other by symbol paths
    relative to the enclosing scene (`@mesh::@primitive::@attribute`). A
    computed attribute (`yasps.attr`) has a region whose SSA values are
    *per-instance* matrices of type `!yasps.mat<r x c x f64>`; the region is
    evaluated independently for every instance of the owner. Only `yasps.join`
    (through a connectivity) and `yasps.union` (over a primitive union) read
    attributes of other primitive types: every other read must stay on the
    owner's lineage (the owner, its mesh, its scene).
  }];
  let useDefaultTypePrinterParser = 1;
  let useDefaultAttributePrinterParser = 1;
  // The discardable attributes that passes agree on, declared once here:
  // their names are the helpers' getNameStr() (Yasps.h names them), and
  // the verifier checks that they hold the dialect's typed attributes.
  let discardableAttrs = (ins
    // The local parameter groups of a derivative (#yasps.param, ...).
    "::mlir::ArrayAttr":$params,
    "::mlir::yasps::DerivativeAttr":$derivative,
    "::mlir::yasps::ProjectionKindAttr":$projection,
    // Set on lowered kernels: the attribute they evaluate, their buffer
    // arguments (#yasps.kernel_arg, ...), output shape and op counts.
    "::mlir::SymbolRefAttr":$kernel_of,
    "::mlir::ArrayAttr":$kernel_args,
    "::mlir::DenseI64ArrayAttr":$kernel_shape,
    "::mlir::DictionaryAttr":$op_counts
  );
  let hasOperationAttrVerify = 1;
  let extraClassDeclaration = [{
    void registerAttributes();
  }];
  let hasConstantMaterializer = 1;
}

class Yasps_Op<string mnemonic, list<Trait> traits = []>
    : Op<Yasps_Dialect, mnemonic, traits>;

#endif // YASPS_DIALECT_YASPS_IR_YASPSDIALECT_TD
