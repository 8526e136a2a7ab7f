//===- YaspsStructureOps.td - scenes, meshes, primitives -----*- tablegen -*-===//
//
// The scene structure of the YASPS paper (section 4.1-4.7, appendix F): the
// entities (scene, mesh, primitive, primitive union), connectivities, the
// attribute declarations that live on entities, energies and minimisation
// targets.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSSTRUCTUREOPS_TD
#define YASPS_DIALECT_YASPS_IR_YASPSSTRUCTUREOPS_TD

include "yasps/Dialect/Yasps/IR/YaspsDialect.td"
include "yasps/Dialect/Yasps/IR/YaspsEnums.td"
include "yasps/Dialect/Yasps/IR/YaspsTypes.td"
include "mlir/IR/SymbolInterfaces.td"
include "mlir/IR/OpAsmInterface.td"

def Yasps_AttributeOwner : ParentOneOf<["SceneOp", "MeshOp", "PrimitiveOp",
                                        "PrimitiveUnionOp"]>;

class Yasps_EntityOp<string mnemonic, list<Trait> traits = []>
    : Yasps_Op<mnemonic, !listconcat(traits, [
        Symbol, SymbolTable, NoTerminator, SingleBlock])> {
  let regions = (region SizedRegion<1>:$body);
  code entityClassDecl = [{
    /// The block holding the entity's children.
    ::mlir::Block &getBodyBlock() { return getBody().front(); }
  }];
  let extraClassDeclaration = entityClassDecl;
  let skipDefaultBuilders = 1;
  let builders = [
    OpBuilder<(ins "::llvm::StringRef":$name), [{
      build($_builder, $_state, $_builder.getStringAttr(name));
    }]>,
    OpBuilder<(ins "::mlir::StringAttr":$sym_name), [{
      $_state.addAttribute(getSymNameAttrName($_state.name), sym_name);
      $_state.addRegion()->emplaceBlock();
    }]>
  ];
}

def Yasps_SceneOp : Yasps_EntityOp<"scene", [IsolatedFromAbove,
                                             HasParent<"::mlir::ModuleOp">]> {
  let summary = "the global scope of a simulation";
  let description = [{
    A scene holds meshes, scene-level attributes (e.g. the time step), energy
    registrations and at most one list of minimisation targets. Symbol paths
    inside a scene (`@mesh::@primitive::@attribute`) are relative to it.

    ```mlir
    yasps.scene @scene0 {
      yasps.const_attr @dt : !yasps.mat<1x1xf64>
      yasps.mesh @cloth { ... }
    }
    ```
  }];
  let arguments = (ins SymbolNameAttr:$sym_name);
  let assemblyFormat = "$sym_name attr-dict-with-keyword $body";
  let hasVerifier = 1;
}

def Yasps_MeshOp : Yasps_EntityOp<"mesh", [HasParent<"SceneOp">]> {
  let summary = "a group of primitive types and primitive unions";
  let description = [{
    A mesh groups primitive types and primitive unions and may carry
    mesh-level attributes, visible to every primitive of the mesh.

    ```mlir
    yasps.mesh @bunny {
      yasps.primitive @vertices(1000) { ... }
    }
    ```
  }];
  let arguments = (ins SymbolNameAttr:$sym_name);
  let assemblyFormat = "$sym_name attr-dict-with-keyword $body";
}

def Yasps_PrimitiveOp : Yasps_EntityOp<"primitive", [HasParent<"MeshOp">]> {
  let summary = "a primitive type: a collection of instances";
  let description = [{
    A primitive type (vertices, tetrahedra, affine bodies, collision pairs...)
    is a set of `num_instances` instances. It holds attributes and
    connectivities. A `dynamic` primitive (collision pairs) changes its
    instance count and connectivity at run time without recompilation; its
    `num_instances` is only the initial count.

    ```mlir
    yasps.primitive @pp(0) dynamic {
      yasps.connectivity @pp2v -> @bunnies::@vertices arity 2
    }
    ```
  }];
  let arguments = (ins SymbolNameAttr:$sym_name,
                       ConfinedAttr<I64Attr, [IntNonNegative]>:$num_instances,
                       UnitAttr:$dynamic);
  let assemblyFormat = [{
    $sym_name `(` $num_instances `)` (`dynamic` $dynamic^)?
    attr-dict-with-keyword $body
  }];
  let builders = [
    OpBuilder<(ins "::llvm::StringRef":$name, "int64_t":$numInstances,
                   "bool":$dynamic), [{
      $_state.addAttribute(getSymNameAttrName($_state.name),
                           $_builder.getStringAttr(name));
      $_state.addAttribute(getNumInstancesAttrName($_state.name),
                           $_builder.getI64IntegerAttr(numInstances));
      if (dynamic)
        $_state.addAttribute(getDynamicAttrName($_state.name),
                             $_builder.getUnitAttr());
      $_state.addRegion()->emplaceBlock();
    }]>
  ];
}

def Yasps_PrimitiveUnionOp : Yasps_EntityOp<"primitive_union", [
    HasParent<"MeshOp">,
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "a primitive type formed by the disjoint union of others";
  let description = [{
    A primitive union declares which primitives (or other unions, possibly of
    other meshes) it unifies. Its instances are the tagged pairs (member,
    instance) of the paper's section 4.6.2, numbered member after member.
    Attributes of a union are usually `yasps.union` reads of the same-named
    attribute of every member. A union has at most `kMaxMembers` (256)
    members: kernels decode a union index by comparing it with each member's
    first instance, and the paper's scenes need four.

    ```mlir
    yasps.primitive_union @vertices [@soft::@vertices, @affine::@vertices] {
      yasps.attr @position : !yasps.mat<3x1xf64> {
        %0 = yasps.union @position : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
    ```
  }];
  let arguments = (ins SymbolNameAttr:$sym_name, SymbolRefArrayAttr:$members);
  let assemblyFormat = "$sym_name $members attr-dict-with-keyword $body";
  let builders = [
    OpBuilder<(ins "::llvm::StringRef":$name, "::mlir::ArrayAttr":$members), [{
      $_state.addAttribute(getSymNameAttrName($_state.name),
                           $_builder.getStringAttr(name));
      $_state.addAttribute(getMembersAttrName($_state.name), members);
      $_state.addRegion()->emplaceBlock();
    }]>
  ];
  let extraClassDeclaration = entityClassDecl # [{
    /// The member entities (primitives or unions), in declaration order.
    /// Empty entries stand for members that do not resolve.
    ::llvm::SmallVector<::mlir::Operation *> getMemberOps();
    /// The most members a union may have (the verifier's limit).
    static constexpr int64_t kMaxMembers = 256;
  }];
  let hasVerifier = 1;
}

def Yasps_ConnectivityOp : Yasps_Op<"connectivity", [
    Symbol, HasParent<"PrimitiveOp">,
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "a map from each instance to `arity` instances of a target";
  let description = [{
    A connectivity of arity `k` from its enclosing primitive A to a target
    primitive or primitive union B maps every instance of A to a `k`-tuple of
    instances of B (paper section 4.4). The indices themselves are run-time
    data (an int32 array of N*k entries); the IR records only the shape.
    The arity is at most 16384: a JOIN through it gathers `k` values into
    one matrix, which has at most that many entries.

    ```mlir
    yasps.primitive @tets(4000) {
      yasps.connectivity @tet2v -> @bunny::@vertices arity 4
    }
    ```
  }];
  let arguments = (ins SymbolNameAttr:$sym_name, SymbolRefAttr:$target,
                       ConfinedAttr<I64Attr, [IntPositive,
                                              IntMaxValue<16384>]>:$arity);
  let assemblyFormat = "$sym_name `->` $target `arity` $arity attr-dict";
}

class Yasps_StoredAttrOp<string mnemonic>
    : Yasps_Op<mnemonic, [Symbol, Yasps_AttributeOwner]> {
  let arguments = (ins SymbolNameAttr:$sym_name,
                       TypeAttrOf<Yasps_MatrixType>:$type);
  let assemblyFormat = "$sym_name `:` $type attr-dict";
  let extraClassDeclaration = [{
    ::mlir::yasps::MatrixType getMatrixType() {
      return ::llvm::cast<::mlir::yasps::MatrixType>(getType());
    }
  }];
}

def Yasps_DataAttrOp : Yasps_StoredAttrOp<"data_attr"> {
  let summary = "a stored attribute that can be a minimisation target";
  let description = [{
    A per-instance array of values owned by a scene, mesh, primitive or
    primitive union, written by the user (`addAttribute(name, rows=, cols=)`).
    It is differentiable: energies can be minimised with respect to it.

    ```mlir
    yasps.data_attr @position : !yasps.mat<3x1xf64>
    ```
  }];
}

def Yasps_ConstAttrOp : Yasps_StoredAttrOp<"const_attr"> {
  let summary = "a stored attribute that is never differentiated";
  let description = [{
    A per-instance array of values like `yasps.data_attr`, but derivatives with
    respect to it are always zero (`addConstant`). Its values may still change
    between solves (e.g. the rest positions or the previous time step).

    ```mlir
    yasps.const_attr @rest_position : !yasps.mat<3x1xf64>
    ```
  }];
}

def Yasps_AttrOp : Yasps_Op<"attr", [
    Symbol, Yasps_AttributeOwner, IsolatedFromAbove,
    DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "a named computed attribute";
  let description = [{
    A per-instance value computed by its region, evaluated independently for
    every instance of the owner (`addAttribute(name, computed_attribute=)`,
    also JOIN and UNION attributes). The region reads other attributes with
    `yasps.read`, `yasps.join` and `yasps.union` and ends in `yasps.yield`.

    Lineage rule (paper 4.3): every `yasps.read` names an attribute of the
    owner or of one of its ancestors, and the owner is the deepest entity
    among the attributes read (a computation on vertex and mesh attributes
    belongs to the vertices; one on mesh attributes alone belongs to the
    mesh). Regions without reads may live anywhere.

    ```mlir
    yasps.attr @dotted2 : !yasps.mat<1x1xf64> {
      %0 = yasps.read @bunny::@vertices::@rest_position : !yasps.mat<3x1xf64>
      %1 = yasps.dot %0, %0 : !yasps.mat<3x1xf64>
      %2 = yasps.constant dense<2.0> : tensor<1x1xf64>
      %3 = yasps.scale %1, %2 : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
      yasps.yield %3 : !yasps.mat<1x1xf64>
    }
    ```
  }];
  let arguments = (ins SymbolNameAttr:$sym_name,
                       TypeAttrOf<Yasps_MatrixType>:$type);
  let regions = (region SizedRegion<1>:$body);
  let assemblyFormat = "$sym_name `:` $type attr-dict-with-keyword $body";
  let extraClassDeclaration = [{
    ::mlir::yasps::MatrixType getMatrixType() {
      return ::llvm::cast<::mlir::yasps::MatrixType>(getType());
    }
    ::mlir::Block &getBodyBlock() { return getBody().front(); }
  }];
  let hasVerifier = 1;
}

def Yasps_EnergyOp : Yasps_Op<"energy", [
    HasParent<"SceneOp">, DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "registers a 1x1 attribute as an energy term";
  let description = [{
    The total energy of the scene is the sum over all instances of every
    registered attribute. `dynamic_instances` marks energies on dynamic
    primitives (collision pairs) whose instance count changes at run time.
    `projection` says how the energy's local Hessians are made positive
    semi-definite (`clamp`, the default, sets negative eigenvalues to zero;
    `abs` flips them; `none` keeps the Hessian).

    ```mlir
    yasps.energy @bunnies::@pp::@barrier dynamic_instances
    yasps.energy @cloth::@hinges::@bending projection abs
    ```
  }];
  let arguments = (ins SymbolRefAttr:$attribute, UnitAttr:$dynamic_instances,
                       DefaultValuedAttr<Yasps_ProjectionMethod,
                                         "::mlir::yasps::ProjectionMethod::clamp">:$projection);
  let assemblyFormat = [{
    $attribute (`dynamic_instances` $dynamic_instances^)?
    (`projection` $projection^)? attr-dict
  }];
}

def Yasps_MinimizeOp : Yasps_Op<"minimize", [
    HasParent<"SceneOp">, DeclareOpInterfaceMethods<SymbolUserOpInterface>]> {
  let summary = "the data attributes the energy is minimised over";
  let description = [{
    Lists the minimisation targets in the order in which solutions are
    returned. Every target is a `yasps.data_attr`; a scene has at most one
    `yasps.minimize`.

    ```mlir
    yasps.minimize [@soft::@vertices::@position, @affine::@body::@matrix]
    ```
  }];
  let arguments = (ins SymbolRefArrayAttr:$targets);
  let assemblyFormat = "$targets attr-dict";
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSSTRUCTUREOPS_TD
