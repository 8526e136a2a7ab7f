//===- Passes.td - yasps transformation passes ---------------*- tablegen -*-===//

#ifndef YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_TD
#define YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_TD

include "mlir/Pass/PassBase.td"

def YaspsInlineReads : Pass<"yasps-inline-reads", "::mlir::ModuleOp"> {
  let summary = "Inline reads of computed attributes on the same lineage";
  let description = [{
    Replaces every `yasps.read` of a computed attribute (`yasps.attr`) by a
    copy of that attribute's region, repeatedly, so that each computed
    attribute becomes one expression over stored attributes (data and
    constants) and the boundary ops `yasps.join` and `yasps.union`. This is
    how an attribute is evaluated without materialising its intermediates
    (paper section 4.3, Fig. 6). JOIN and UNION are kept: they cross to
    another primitive and are evaluated by their own kernels.

    Run `cse` afterwards to merge the copies of shared subexpressions.

    ```mlir
    // before
    yasps.attr @d : !yasps.mat<1x1xf64> {
      %0 = yasps.read @m::@v::@x : !yasps.mat<3x1xf64>
      ...
    }
    yasps.attr @e : !yasps.mat<1x1xf64> {
      %0 = yasps.read @m::@v::@d : !yasps.mat<1x1xf64>
      ...
    }
    // after: @e reads @m::@v::@x directly
    ```
  }];
  let dependentDialects = ["::mlir::yasps::YaspsDialect"];
  let statistics = [
    Statistic<"numInlined", "num-inlined", "Number of reads inlined">
  ];
}

def YaspsStripScenes : Pass<"yasps-strip-scenes", "::mlir::ModuleOp"> {
  let summary = "Erase the scene description once kernels are generated";
  let description = [{
    Removes every `yasps.scene` op, leaving the generated kernel functions in
    upstream dialects only, ready for lowering to LLVM or GPU code.
  }];
}

def YaspsDifferentiate : Pass<"yasps-differentiate", "::mlir::ModuleOp"> {
  let summary = "Local gradients and Hessians of every energy";
  let description = [{
    For every energy `@E` of a scene with minimisation targets, adds to E's
    owner the computed attributes

    - `@E__grad : !yasps.mat<n x 1>`: the gradient of one instance of E with
      respect to its n local parameters, and
    - `@E__hess : !yasps.mat<n x n>`: its Hessian,

    both as yasps IR built from the ops' derivative rules
    (`DifferentiableOpInterface`): forward mode, one tangent per local
    parameter, and the rules applied again to the tangent code for second
    derivatives, with tangents known to be zero never materialised. Both list
    their parameters in `yasps.params`, in order: `["read", @attr]` for a
    target read on the energy's own lineage (its r*c entries, column-major),
    `["join", @connectivity, l, @attr]` for the l-th instance gathered by a
    JOIN of a target (r*c entries each).

    Energies must have their reads of computed attributes inlined
    (`yasps-inline-reads`). Differentiating through a JOIN or UNION of a
    computed attribute (e.g. affine-body vertices) is not supported yet and
    is reported as an error on the op.
  }];
  let dependentDialects = ["::mlir::yasps::YaspsDialect"];
}

#endif // YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_TD
