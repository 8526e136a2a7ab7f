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

def YaspsDifferentiate : Pass<"yasps-differentiate", "::mlir::ModuleOp"> {
  let summary = "Jacobians of attributes; local gradients and Hessians of energies";
  let description = [{
    For every energy `@E` of a scene with minimisation targets, adds next to
    it `@E__grad : !yasps.mat<n x 1>` and `@E__hess : !yasps.mat<n x n>`, the
    gradient and Hessian of one instance with respect to its n local
    parameters, listed in `yasps.params`.

    The unit is the Jacobian `@X__jac` (rc x d) of an attribute X with
    respect to its local parameters: groups of target entries that X reaches
    through its region's leaves. A read of a target gives its r*c entries
    (`#yasps.param<read @target>`); a JOIN gives, per gathered instance, the
    parameters of its source's base attribute (`#yasps.param<join
    @conn[slot] of @base, width w>`): r*c entries of a stored target, or,
    for a computed source, that source's own parameters; a UNION gives the
    parameters of the member the instance belongs to, padded to the widest
    member (`#yasps.param<union @name of @union, width w>`, paper 5.2).
    Where the energy reaches its leaves through a linear cut with fewer
    entries still (values affine in the leaves that every path from a leaf
    crosses, such as a tet's deformation gradient), the projection is taken
    in the cut's entries instead (paper 10.4, done by the compiler; option
    `linear-maps`).
    Every attribute it adds records what it is, e.g.
    `yasps.derivative = #yasps.derivative<grad of @m::@t::@E>`, and
    projected Hessians how they are projected
    (`yasps.projection = #yasps.projection<reduced>`).

    Each Jacobian is built in forward mode from the ops' derivative rules
    (`DifferentiableOpInterface`): one tangent per parameter, seeded with
    unit matrices at target leaves and, at a JOIN or UNION of a computed
    attribute, with that attribute's own Jacobian gathered the same way
    (paper 5.1): a boundary attribute is differentiated once and reused by
    every energy that gathers it. A derivative attribute has its base's
    parameters, so `@E__hess` is the Jacobian of `@E__jac`, and the
    curvature terms of nonlinear parameterisations come from the sources'
    second Jacobians. Energies must have their reads of computed attributes
    inlined first (`yasps-inline-reads`).
  }];
  let options = [
    Option<"hessianFactors", "hessian-factors",
           "::mlir::yasps::HessianFactors",
           /*default=*/"::mlir::yasps::HessianFactors::never",
           "Where the reduced-space projection applies, whether to keep the "
           "inner map J (@E__ij, m x n), the projected inner Hessian "
           "(@E__hess_inner_proj, m x m) and the unprojected one "
           "(@E__hess_inner) as attributes instead of forming "
           "@E__hess_proj = J^T P(H_inner) J, so that the runtime forms the "
           "product while it assembles (paper 7.2, 10.9): never, always, or "
           "auto (when the factors hold at most half the values of the "
           "n x n Hessian: 2 m (n + m) <= n^2)",
           [{::mlir::yasps::hessianFactorsValues()}]>,
    Option<"linearMaps", "linear-maps", "bool", /*default=*/"true",
           "Where the leaves reach the energy through a linear cut with "
           "fewer entries (the deformation gradient F of a tet: 9 against "
           "12 positions), project the Hessian in the cut's entries: "
           "@E__hess_proj = J^T P(H_cut) J with @E__ij = d(cut)/d(params) "
           "and @E__ihess the k x k Hessian in the cut (paper 10.4, "
           "automatically)">
  ];
  let dependentDialects = ["::mlir::yasps::YaspsDialect"];
}

def YaspsGenerateIndices : Pass<"yasps-generate-indices", "::mlir::ModuleOp"> {
  let summary = "Placement indices of energies' local parameters as attributes";
  let description = [{
    For every energy `E` that `yasps-differentiate` gave derivatives, adds
    `@E__dofs : !yasps.mat<n x 1>`: for each of the n local parameters of
    `@E__grad`, its global DoF number counted from 1, or 0 for the zero
    padding of UNION slots (paper appendix A.3). It is computed from the
    same IR as the derivatives, by kernels, following `yasps.params`:

    - a target read is `yasps.dof_index` of the target;
    - a JOIN slot gathers the source's `@S__dofs` through the connectivity
      and takes the slot's row;
    - a UNION slot reads `yasps.union @name__udofs<w>`, every member's
      `@name__dofs` padded with zeros to the slot's width w.

    A source's `@S__dofs` (on its own entity, built from its `@S__jac`'s
    parameters) is shared by every energy that gathers it. Run after
    `yasps-differentiate`.
  }];
  let dependentDialects = ["::mlir::yasps::YaspsDialect"];
}

#endif // YASPS_DIALECT_YASPS_TRANSFORMS_PASSES_TD
