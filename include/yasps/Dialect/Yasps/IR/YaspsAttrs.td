//===- YaspsAttrs.td - yasps attributes ----------------------*- tablegen -*-===//
//
// The contracts between the passes, the kernel generator and the runtime:
// what a derivative's local parameters are (`yasps.params`), what a derived
// attribute is (`yasps.derivative`, `yasps.projection`) and what each
// argument of a generated kernel holds (`yasps.kernel_args`).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_DIALECT_YASPS_IR_YASPSATTRS_TD
#define YASPS_DIALECT_YASPS_IR_YASPSATTRS_TD

include "yasps/Dialect/Yasps/IR/YaspsDialect.td"
include "yasps/Dialect/Yasps/IR/YaspsEnums.td"
include "mlir/IR/AttrTypeBase.td"
include "mlir/IR/EnumAttr.td"

class Yasps_Attr<string name, string attrMnemonic>
    : AttrDef<Yasps_Dialect, name> {
  let mnemonic = attrMnemonic;
}

def Yasps_ParamAttr : Yasps_Attr<"Param", "param"> {
  let summary = "one slot of a derivative's local parameters";
  let description = [{
    An entry of `yasps.params`, the local parameters of a derivative
    attribute (yasps-differentiate): one slot of parameters, reached

    - `read @target`: by a read of a minimisation target, its r*c entries;
    - `join @conn[slot] of @base, width w`: through instance `slot` of a
      JOIN over connectivity `@conn`, the w parameters of the source's base
      attribute `@base` (scene-relative);
    - `union @attr of @union, width w`: through a UNION over `@union`, the
      parameters of attribute `@attr` of the instance's member, padded to w.

    ```mlir
    yasps.params = [#yasps.param<join @t2v[0] of @m::@v::@x, width 3>,
                    #yasps.param<union @x of @w::@u, width 12>]
    ```
  }];
  let parameters = (ins EnumParameter<Yasps_ParamKind>:$kind,
                        "::mlir::SymbolRefAttr":$path,
                        OptionalParameter<"::mlir::FlatSymbolRefAttr">:$via,
                        "int64_t":$slot, "int64_t":$width);
  let hasCustomAssemblyFormat = 1;
  let genVerifyDecl = 1;
  let builders = [
    AttrBuilder<(ins "::mlir::SymbolRefAttr":$target), [{
      return $_get($_ctxt, ParamKind::read, target, FlatSymbolRefAttr(), 0, 0);
    }]>
  ];
  let extraClassDeclaration = [{
    /// `join @connectivity[slot] of @base, width w`.
    static ParamAttr getJoin(FlatSymbolRefAttr connectivity, int64_t slot,
                             SymbolRefAttr base, int64_t width) {
      return get(base.getContext(), ParamKind::join, base, connectivity, slot,
                 width);
    }
    /// `union @attribute of @unionEntity, width w`.
    static ParamAttr getUnion(SymbolRefAttr unionEntity,
                              FlatSymbolRefAttr attribute, int64_t width) {
      return get(unionEntity.getContext(), ParamKind::union_, unionEntity,
                 attribute, 0, width);
    }
  }];
}

def Yasps_KernelArgAttr : Yasps_Attr<"KernelArg", "kernel_arg"> {
  let summary = "what one buffer argument of a generated kernel holds";
  let description = [{
    An entry of `yasps.kernel_args` (yasps-lower-to-loops), one per buffer
    argument after the instance range: the kernel's output (`out`), a stored
    attribute's values (`attr`), a connectivity (`conn`), the member offsets
    of a union (`offsets`) or the scene's DoF offsets (`dof_offsets`), with
    the scene-relative path of what it holds (the scene itself for
    `dof_offsets`).

    ```mlir
    yasps.kernel_args = [#yasps.kernel_arg<out @m::@t::@e>,
                         #yasps.kernel_arg<conn @m::@t::@t2v>]
    ```
  }];
  let parameters = (ins EnumParameter<Yasps_KernelArgKind>:$kind,
                        "::mlir::SymbolRefAttr":$path);
  let assemblyFormat = "`<` $kind $path `>`";
}

def Yasps_DerivativeAttr : Yasps_Attr<"Derivative", "derivative"> {
  let summary = "what a derived attribute holds about its base";
  let description = [{
    `yasps.derivative` of an attribute that yasps-differentiate or
    yasps-generate-indices created: its role and the scene-relative path of
    the attribute it derives from. Passes and the runtime find derivatives
    by this record, not by their names.

    ```mlir
    yasps.attr @e__hess_proj : !yasps.mat<12x12xf64> attributes {
        yasps.derivative = #yasps.derivative<hess_proj of @m::@t::@e>, ...}
    ```
  }];
  let parameters = (ins EnumParameter<Yasps_DerivativeRole>:$role,
                        "::mlir::SymbolRefAttr":$of);
  let assemblyFormat = "`<` $role `of` $of `>`";
}

def Yasps_ProjectionAttr
    : EnumAttr<Yasps_Dialect, Yasps_ProjectionKind, "projection"> {
  let summary = "how a projected local Hessian is formed";
  let description = [{
    `yasps.projection` of a projected Hessian: `full` (the local Hessian is
    projected), `reduced` (J^T P(H_inner) J in the leaf entries, paper 5.4)
    or `separate` (only P(H_inner); the runtime forms the product).
  }];
  let assemblyFormat = "`<` $value `>`";
}

#endif // YASPS_DIALECT_YASPS_IR_YASPSATTRS_TD
