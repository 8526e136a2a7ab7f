// RUN: yasps-opt %s | yasps-opt | FileCheck %s

// The passes' contracts print and parse back.
// CHECK-LABEL: yasps.attr @e__grad
// CHECK-SAME: yasps.derivative = #yasps.derivative<grad of @m::@t::@e>
// CHECK-SAME: yasps.params = [#yasps.param<read @m::@t::@x>, #yasps.param<join @t2v[2] of @m::@v::@y, width 3>, #yasps.param<union @y of @m::@u, width 12>]
// CHECK-SAME: yasps.projection = #yasps.projection<separate>
// CHECK-LABEL: func.func @kernel
// CHECK-SAME: yasps.kernel_args = [#yasps.kernel_arg<out @m::@t::@e>, #yasps.kernel_arg<conn @m::@t::@t2v>, #yasps.kernel_arg<dof_offsets @s>]
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @t(1) {
      yasps.attr @e__grad : !yasps.mat<1x1xf64> attributes {
          yasps.derivative = #yasps.derivative<grad of @m::@t::@e>,
          yasps.params = [#yasps.param<read @m::@t::@x>,
                          #yasps.param<join @t2v[2] of @m::@v::@y, width 3>,
                          #yasps.param<union @y of @m::@u, width 12>],
          yasps.projection = #yasps.projection<separate>} {
        %0 = yasps.constant dense<0.0> : tensor<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}
func.func @kernel() attributes {
    yasps.kernel_args = [#yasps.kernel_arg<out @m::@t::@e>,
                         #yasps.kernel_arg<conn @m::@t::@t2v>,
                         #yasps.kernel_arg<dof_offsets @s>]} {
  return
}
