// RUN: yasps-opt %s -split-input-file -yasps-differentiate -canonicalize -cse | FileCheck %s

// A spring through a JOIN of the target positions: 6 local parameters, two
// per-instance derivative attributes next to the energy, the energy's own
// computation reused inside them.

// CHECK-LABEL: yasps.attr @spring : !yasps.mat<1x1xf64>
// CHECK: yasps.attr @spring__grad : !yasps.mat<6x1xf64> attributes {yasps.params = {{\[\[}}"join", @e2v, 0, @m::@v::@x], ["join", @e2v, 1, @m::@v::@x]]}
// CHECK: yasps.join @e2v(@m::@v::@x)
// CHECK: yasps.norm
// CHECK: yasps.concat vertical
// CHECK: yasps.yield %{{.*}} : !yasps.mat<6x1xf64>
// CHECK: yasps.attr @spring__hess : !yasps.mat<6x6xf64> attributes {yasps.params = {{\[\[}}"join", @e2v, 0, @m::@v::@x], ["join", @e2v, 1, @m::@v::@x]]}
// CHECK: yasps.yield %{{.*}} : !yasps.mat<6x6xf64>
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(3) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(2) {
      yasps.const_attr @rest : !yasps.mat<1x1xf64>
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @spring : !yasps.mat<1x1xf64> {
        %p = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
        %l0 = yasps.read @m::@e::@rest : !yasps.mat<1x1xf64>
        %a = yasps.row %p[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %b = yasps.row %p[1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %d = yasps.sub %b, %a : !yasps.mat<1x3xf64>
        %n = yasps.norm %d : !yasps.mat<1x3xf64>
        %s = yasps.sub %n, %l0 : !yasps.mat<1x1xf64>
        %e = yasps.scale %s, %s : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@e::@spring
  yasps.minimize [@m::@v::@x]
}

// -----

// Matrix-level rules: the derivative of det(A) stays in terms of det and
// inverse, not a scalar expansion. A direct read of the target gives 4
// parameters (column-major entries); the Hessian of det on 2x2 is constant
// structure around the inverse.

// CHECK-LABEL: yasps.attr @d__grad : !yasps.mat<4x1xf64> attributes {yasps.params = {{\[\[}}"read", @m::@p::@a]]}
// CHECK: %[[A:.*]] = yasps.read @m::@p::@a
// CHECK-DAG: yasps.det %[[A]]
// CHECK-DAG: yasps.inverse %[[A]]
// CHECK: yasps.trace
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<2x2xf64>
      yasps.attr @d : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<2x2xf64>
        %d = yasps.det %a : !yasps.mat<2x2xf64>
        yasps.yield %d : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@d
  yasps.minimize [@m::@p::@a]
}

// -----

// Energies that read no target get no derivative attributes; reads of
// constants are not parameters.

// CHECK-LABEL: yasps.attr @c :
// CHECK-NOT: @c__grad
// CHECK: yasps.attr @e__grad : !yasps.mat<3x1xf64> attributes {yasps.params = {{\[\[}}"read", @m::@p::@x]]}
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.const_attr @k : !yasps.mat<3x1xf64>
      yasps.attr @c : !yasps.mat<1x1xf64> {
        %k = yasps.read @m::@p::@k : !yasps.mat<3x1xf64>
        %n = yasps.squared_norm %k : !yasps.mat<3x1xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x1xf64>
        %k = yasps.read @m::@p::@k : !yasps.mat<3x1xf64>
        %n = yasps.dot %x, %k : !yasps.mat<3x1xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@c
  yasps.energy @m::@p::@e
  yasps.minimize [@m::@p::@x]
}
