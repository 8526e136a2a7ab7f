// RUN: yasps-opt %s -yasps-differentiate=hessian-factors=always -canonicalize -cse | FileCheck %s
// RUN: yasps-opt %s -yasps-differentiate=hessian-factors=auto -canonicalize -cse | FileCheck %s
// RUN: yasps-opt %s -yasps-differentiate=hessian-factors=never -canonicalize -cse | FileCheck %s --check-prefix=NEVER

// With hessian-factors=always, or auto (2 m (n + m) = 360 <= n^2 = 576),
// the barrier over free and affine-body vertices keeps its reduced-space
// factors apart (paper 7.2, 10.9): the inner map J (6x24, with the
// parameters' yasps.params), the unprojected and the projected 6x6 inner
// Hessian, instead of the 24x24 product J^T P J. With never, the kernel
// forms the product.
// NEVER: yasps.attr @e__hess_proj : !yasps.mat<24x24xf64> attributes {{{.*}}yasps.projection = #yasps.projection<reduced>}
// NEVER-NOT: @e__hess_inner
// CHECK-LABEL: yasps.primitive @pp(2) dynamic
// CHECK: yasps.attr @e__ij : !yasps.mat<6x24xf64> attributes {{{.*}}yasps.params = [#yasps.param<join @p2v[0] of @w::@u::@x, width 12>, #yasps.param<join @p2v[1] of @w::@u::@x, width 12>]}
// CHECK: yasps.attr @e__hess_inner : !yasps.mat<6x6xf64> attributes {yasps.derivative = #yasps.derivative<hess_inner of @w::@pp::@e>
// CHECK-NEXT: yasps.read @w::@pp::@e__ijac__ijac : !yasps.mat<6x6xf64>
// CHECK: yasps.attr @e__hess_inner_proj : !yasps.mat<6x6xf64> attributes {{{.*}}yasps.projection = #yasps.projection<separate>}
// CHECK-NEXT: yasps.read @w::@pp::@e__ijac__ijac : !yasps.mat<6x6xf64>
// CHECK-NEXT: yasps.project clamp %{{.*}} : !yasps.mat<6x6xf64>
// CHECK-NOT: yasps.matmul
// CHECK: yasps.attr @e__hess : !yasps.mat<24x24xf64>
// CHECK-NOT: @e__hess_proj
yasps.scene @sc {
  yasps.mesh @r {
    yasps.primitive @b(1) {
      yasps.data_attr @A : !yasps.mat<3x3xf64>
      yasps.data_attr @t : !yasps.mat<3x1xf64>
    }
    yasps.primitive @v(1) {
      yasps.const_attr @rest : !yasps.mat<3x1xf64>
      yasps.connectivity @v2b -> @r::@b arity 1
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %a = yasps.join @v2b(@r::@b::@A) : !yasps.mat<1x9xf64>
        %t = yasps.join @v2b(@r::@b::@t) : !yasps.mat<1x3xf64>
        %r = yasps.read @r::@v::@rest : !yasps.mat<3x1xf64>
        %m = yasps.resize %a : !yasps.mat<1x9xf64> -> !yasps.mat<3x3xf64>
        %tc = yasps.resize %t : !yasps.mat<1x3xf64> -> !yasps.mat<3x1xf64>
        %p = yasps.matmul %m, %r : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x1xf64>
        %x = yasps.add %p, %tc : !yasps.mat<3x1xf64>
        yasps.yield %x : !yasps.mat<3x1xf64>
      }
    }
  }
  yasps.mesh @s {
    yasps.primitive @v(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
  }
  yasps.mesh @w {
    yasps.primitive_union @u [@r::@v, @s::@v] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
    yasps.primitive @pp(2) dynamic {
      yasps.connectivity @p2v -> @w::@u arity 2
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %p = yasps.join @p2v(@w::@u::@x) : !yasps.mat<2x3xf64>
        %d = yasps.squared_norm %p : !yasps.mat<2x3xf64>
        yasps.yield %d : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @w::@pp::@e dynamic_instances
  yasps.minimize [@s::@v::@x, @r::@b::@A, @r::@b::@t]
}
