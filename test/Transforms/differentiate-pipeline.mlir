// RUN: yasps-opt %s --yasps-differentiate-pipeline | FileCheck %s
// RUN: yasps-opt %s --yasps-differentiate-pipeline=hessian-factors=always | FileCheck %s --check-prefix=SEPARATE

// The energy reads a computed attribute, which yasps-differentiate alone
// rejects: the pipeline inlines it first, then adds the derivatives and
// their placement indices. Its two points are vertices of a UNION of
// affine-body vertices (12 parameters) and free ones (3, padded to 12).
// Each derived attribute records its role and base, and its parameters.
// CHECK-LABEL: yasps.primitive_union @u
// CHECK: yasps.attr @x__jac : !yasps.mat<3x12xf64> attributes {yasps.derivative = #yasps.derivative<jac of @w::@u::@x>, yasps.params = [#yasps.param<union @x of @w::@u, width 12>]}
// CHECK: yasps.attr @x__dofs : !yasps.mat<12x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @w::@u::@x>}
// CHECK-LABEL: yasps.primitive @pp(2) dynamic
// CHECK: yasps.attr @e__hess_proj : !yasps.mat<24x24xf64> attributes {yasps.derivative = #yasps.derivative<hess_proj of @w::@pp::@e>, yasps.params = [#yasps.param<join @p2v[0] of @w::@u::@x, width 12>, #yasps.param<join @p2v[1] of @w::@u::@x, width 12>], yasps.projection = #yasps.projection<reduced>}
// CHECK: yasps.attr @e__grad : !yasps.mat<24x1xf64> attributes {yasps.derivative = #yasps.derivative<grad of @w::@pp::@e>,
// CHECK: yasps.attr @e__hess : !yasps.mat<24x24xf64> attributes {yasps.derivative = #yasps.derivative<hess of @w::@pp::@e>,
// CHECK: yasps.attr @e__dofs : !yasps.mat<24x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @w::@pp::@e>}

// The energy depends on its 24 parameters through the 6 entries of the
// gathered points, linearly: with the option, the reduced-space factors
// stay apart.
// SEPARATE-LABEL: yasps.primitive @pp(2) dynamic
// SEPARATE: yasps.attr @e__ij : !yasps.mat<6x24xf64> attributes {yasps.derivative = #yasps.derivative<ij of @w::@pp::@e>,
// SEPARATE: yasps.attr @e__hess_inner_proj : !yasps.mat<6x6xf64> attributes {{{.*}}yasps.projection = #yasps.projection<separate>}
// SEPARATE-NOT: @e__hess_proj
// SEPARATE: yasps.attr @e__dofs : !yasps.mat<24x1xf64>
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
      yasps.attr @d : !yasps.mat<1x1xf64> {
        %p = yasps.join @p2v(@w::@u::@x) : !yasps.mat<2x3xf64>
        %d = yasps.squared_norm %p : !yasps.mat<2x3xf64>
        yasps.yield %d : !yasps.mat<1x1xf64>
      }
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %d = yasps.read @w::@pp::@d : !yasps.mat<1x1xf64>
        %e = yasps.matmul %d, %d : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64> -> !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @w::@pp::@e dynamic_instances
  yasps.minimize [@s::@v::@x, @r::@b::@A, @r::@b::@t]
}
