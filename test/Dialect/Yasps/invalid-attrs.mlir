// RUN: yasps-opt %s -split-input-file -verify-diagnostics

// One case per rule of the passes' typed contracts (YaspsAttrs.td).

// A parameter is reached by read, join or union.
// expected-error @+1 {{expected 'read', 'join' or 'union', got 'gather'}}
func.func @f() attributes {yasps.params = [#yasps.param<gather @m::@v::@x>]}

// -----

// A JOIN slot carries its parameters' count.
// expected-error @+1 {{a join parameter needs a positive width, got 0}}
func.func @f() attributes {yasps.params = [#yasps.param<join @c[0] of @m::@v::@x, width 0>]}

// -----

// Slots count from 0.
// expected-error @+1 {{invalid slot -1 of a join parameter}}
func.func @f() attributes {yasps.params = [#yasps.param<join @c[-1] of @m::@v::@x, width 3>]}

// -----

// yasps.params holds parameters, not their old positional fields.
// expected-error @+1 {{'yasps.params' must be an array of #yasps.param, got [["read", @m::@v::@x]]}}
func.func @f() attributes {yasps.params = [["read", @m::@v::@x]]}

// -----

// expected-error @+1 {{'yasps.kernel_args' must be an array of #yasps.kernel_arg}}
func.func @f() attributes {yasps.kernel_args = [["out", @m::@v::@x]]}

// -----

// expected-error @+2 {{expected ::mlir::yasps::KernelArgKind to be one of: out, attr, conn, offsets, dof_offsets}}
// expected-error @+1 {{failed to parse Yasps_KernelArgAttr parameter 'kind'}}
func.func @f() attributes {yasps.kernel_args = [#yasps.kernel_arg<in @m::@v::@x>]}

// -----

// expected-error @+1 {{'yasps.projection' must be a #yasps.projection, got "reduced"}}
func.func @f() attributes {yasps.projection = "reduced"}

// -----

// expected-error @+1 {{'yasps.derivative' must be a #yasps.derivative}}
func.func @f() attributes {yasps.derivative = @m::@v::@x}

// -----

// expected-error @+2 {{expected ::mlir::yasps::DerivativeRole to be one of: jac, grad, hess, hess_proj, hess_inner_proj, ij, dofs}}
// expected-error @+1 {{failed to parse Yasps_DerivativeAttr parameter 'role'}}
func.func @f() attributes {yasps.derivative = #yasps.derivative<hessian of @m::@v::@x>}
