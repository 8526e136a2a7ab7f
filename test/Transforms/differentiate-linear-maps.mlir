// RUN: yasps-opt %s -split-input-file -yasps-differentiate -canonicalize -cse | FileCheck %s
// RUN: yasps-opt %s -split-input-file -yasps-differentiate=linear-maps=false -canonicalize -cse | FileCheck %s --check-prefix=LEAVES

// A tet's energy of F = Ds Dm^-1 (paper 10.4): F is affine in the 12
// gathered positions and every path from them crosses it, so the Hessian
// is projected in F's 9 entries: @e__ij (9x12) is dF/dx, @e__ihess the 9x9
// Hessian in F, and @e__hess_proj = J^T P J. F^T, computed from F alone,
// does not join the cut. Without linear maps the 12x12 Hessian is
// projected.

// CHECK-LABEL: yasps.attr @e : !yasps.mat<1x1xf64>
// CHECK: yasps.attr @e__ij : !yasps.mat<9x12xf64> attributes {yasps.derivative = #yasps.derivative<ij of @m::@t::@e>}
// CHECK: yasps.attr @e__ihess : !yasps.mat<9x9xf64>
// CHECK: yasps.attr @e__hess_proj : !yasps.mat<12x12xf64> attributes {{{.*}}yasps.projection = #yasps.projection<reduced>}
// CHECK-NEXT: %[[H:.*]] = yasps.read @m::@t::@e__ihess : !yasps.mat<9x9xf64>
// CHECK-NEXT: %[[P:.*]] = yasps.project clamp %[[H]] : !yasps.mat<9x9xf64>
// CHECK-NEXT: %[[J:.*]] = yasps.read @m::@t::@e__ij : !yasps.mat<9x12xf64>
// CHECK-NEXT: %[[JT:.*]] = yasps.transpose %[[J]]
// CHECK-NEXT: %[[PJ:.*]] = yasps.matmul %[[P]], %[[J]] : !yasps.mat<9x9xf64>, !yasps.mat<9x12xf64> -> !yasps.mat<9x12xf64>
// CHECK-NEXT: yasps.matmul %[[JT]], %[[PJ]] : !yasps.mat<12x9xf64>, !yasps.mat<9x12xf64> -> !yasps.mat<12x12xf64>

// LEAVES-LABEL: yasps.attr @e : !yasps.mat<1x1xf64>
// LEAVES-NOT: @e__ij
// LEAVES: yasps.attr @e__hess_proj : !yasps.mat<12x12xf64> attributes {{{.*}}yasps.projection = #yasps.projection<full>}
// LEAVES: yasps.project clamp %{{.*}} : !yasps.mat<12x12xf64>
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(4) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @t(1) {
      yasps.const_attr @inv : !yasps.mat<3x3xf64>
      yasps.connectivity @t2v -> @m::@v arity 4
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %c = yasps.join @t2v(@m::@v::@x) : !yasps.mat<4x3xf64>
        %r0 = yasps.row %c[0] : !yasps.mat<4x3xf64> -> !yasps.mat<1x3xf64>
        %r1 = yasps.row %c[1] : !yasps.mat<4x3xf64> -> !yasps.mat<1x3xf64>
        %r2 = yasps.row %c[2] : !yasps.mat<4x3xf64> -> !yasps.mat<1x3xf64>
        %r3 = yasps.row %c[3] : !yasps.mat<4x3xf64> -> !yasps.mat<1x3xf64>
        %e1 = yasps.sub %r1, %r0 : !yasps.mat<1x3xf64>
        %e2 = yasps.sub %r2, %r0 : !yasps.mat<1x3xf64>
        %e3 = yasps.sub %r3, %r0 : !yasps.mat<1x3xf64>
        %ds = yasps.concat vertical %e1, %e2, %e3 : !yasps.mat<1x3xf64>, !yasps.mat<1x3xf64>, !yasps.mat<1x3xf64> -> !yasps.mat<3x3xf64>
        %inv = yasps.read @m::@t::@inv : !yasps.mat<3x3xf64>
        %f = yasps.matmul %ds, %inv : !yasps.mat<3x3xf64>, !yasps.mat<3x3xf64> -> !yasps.mat<3x3xf64>
        %ft = yasps.transpose %f : !yasps.mat<3x3xf64> -> !yasps.mat<3x3xf64>
        %c2 = yasps.matmul %ft, %f : !yasps.mat<3x3xf64>, !yasps.mat<3x3xf64> -> !yasps.mat<3x3xf64>
        %tr = yasps.trace %c2 : !yasps.mat<3x3xf64>
        %det = yasps.det %f : !yasps.mat<3x3xf64>
        %l = yasps.log %tr : !yasps.mat<1x1xf64>
        %d2 = yasps.scale %det, %det : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %sum = yasps.add %l, %d2 : !yasps.mat<1x1xf64>
        yasps.yield %sum : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@t::@e
  yasps.minimize [@m::@v::@x]
}

// -----

// A spring reaches its 6 parameters through the edge vector (3 entries):
// a 3x3 projection. Inertia's x - x_hat has as many entries as x: its
// 3x3 Hessian is projected as it is, with no map.

// CHECK-LABEL: yasps.attr @i : !yasps.mat<1x1xf64>
// CHECK-NOT: @i__ij
// CHECK: yasps.attr @i__hess_proj : !yasps.mat<3x3xf64> attributes {{{.*}}yasps.projection = #yasps.projection<full>}
// CHECK-LABEL: yasps.attr @k : !yasps.mat<1x1xf64>
// CHECK: yasps.attr @k__ij : !yasps.mat<3x6xf64>
// CHECK: yasps.attr @k__hess_proj : !yasps.mat<6x6xf64> attributes {{{.*}}yasps.projection = #yasps.projection<reduced>}
// CHECK: yasps.project clamp %{{.*}} : !yasps.mat<3x3xf64>

// LEAVES: yasps.attr @k__hess_proj : !yasps.mat<6x6xf64> attributes {{{.*}}yasps.projection = #yasps.projection<full>}
// LEAVES: yasps.project clamp %{{.*}} : !yasps.mat<6x6xf64>
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(2) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.const_attr @xh : !yasps.mat<3x1xf64>
      yasps.attr @i : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@v::@x : !yasps.mat<3x1xf64>
        %xh = yasps.read @m::@v::@xh : !yasps.mat<3x1xf64>
        %d = yasps.sub %x, %xh : !yasps.mat<3x1xf64>
        %n = yasps.squared_norm %d : !yasps.mat<3x1xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @k : !yasps.mat<1x1xf64> {
        %p = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
        %a = yasps.row %p[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %b = yasps.row %p[1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %d = yasps.sub %b, %a : !yasps.mat<1x3xf64>
        %n = yasps.norm %d : !yasps.mat<1x3xf64>
        %one = yasps.constant dense<1.0> : tensor<1x1xf64>
        %s = yasps.sub %n, %one : !yasps.mat<1x1xf64>
        %e = yasps.scale %s, %s : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@e::@k
  yasps.energy @m::@v::@i
  yasps.minimize [@m::@v::@x]
}

// -----

// Positions nonlinear in the parameters (an angle): no cut applies, the
// full Hessian is projected.

// CHECK-LABEL: yasps.attr @a : !yasps.mat<1x1xf64>
// CHECK-NOT: @a__ij
// CHECK: yasps.projection = #yasps.projection<full>
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @theta : !yasps.mat<2x1xf64>
      yasps.attr @a : !yasps.mat<1x1xf64> {
        %t = yasps.read @m::@p::@theta : !yasps.mat<2x1xf64>
        %c = yasps.cos %t : !yasps.mat<2x1xf64>
        %s = yasps.sum %c : !yasps.mat<2x1xf64>
        %e = yasps.scale %s, %s : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@a
  yasps.minimize [@m::@p::@theta]
}
