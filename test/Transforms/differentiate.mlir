// RUN: yasps-opt %s -split-input-file -yasps-differentiate -canonicalize -cse | FileCheck %s

// A spring through a JOIN of the target positions: 6 local parameters (two
// slots of 3). The Jacobian (1x6) repeats the energy's computation and adds
// one tangent per parameter; the gradient is its transpose and the Hessian
// the Jacobian of the Jacobian.

// CHECK-LABEL: yasps.attr @spring : !yasps.mat<1x1xf64>
// CHECK: yasps.attr @spring__jac : !yasps.mat<1x6xf64> attributes {{{.*}}yasps.params = [#yasps.param<join @e2v[0] of @m::@v::@x, width 3>, #yasps.param<join @e2v[1] of @m::@v::@x, width 3>]}
// CHECK: yasps.join @e2v(@m::@v::@x)
// CHECK: yasps.norm
// CHECK: yasps.concat horizontal
// CHECK: yasps.yield %{{.*}} : !yasps.mat<1x6xf64>
// CHECK: yasps.attr @spring__grad : !yasps.mat<6x1xf64>
// CHECK-NEXT: %[[J:.*]] = yasps.read @m::@e::@spring__jac
// CHECK-NEXT: %[[T:.*]] = yasps.transpose %[[J]]
// CHECK-NEXT: yasps.yield %[[T]]
// CHECK: yasps.attr @spring__hess : !yasps.mat<6x6xf64>
// CHECK-NEXT: yasps.read @m::@e::@spring__jac__jac
// CHECK: yasps.attr @spring__jac__jac : !yasps.mat<6x6xf64>
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

// Matrix-level rules: the derivative of det(A) is <cofactor(A), A'>, which
// stays polynomial (no inverse). A direct read of the target gives 4
// parameters (column-major entries); the Hessian of det on 2x2 is constant:
// the cofactors of the unit directions fold away.

// CHECK-LABEL: yasps.attr @d__jac : !yasps.mat<1x4xf64> attributes {{{.*}}yasps.params = [#yasps.param<read @m::@p::@a>]}
// CHECK: %[[A:.*]] = yasps.read @m::@p::@a
// CHECK: %[[C:.*]] = yasps.cofactor %[[A]]
// CHECK: yasps.dot %[[C]]
// CHECK-NOT: yasps.inverse
// CHECK: yasps.attr @d__jac__jac : !yasps.mat<4x4xf64>
// CHECK-NOT: yasps.read
// CHECK-NOT: yasps.cofactor
// CHECK: yasps.yield
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

// The sum of signed singular values is differentiated implicitly, in terms
// of its own value: the tangent divides by s (s^2 - |A|^2) - 2 det A and
// needs no SVD; the Hessian differentiates that rule again.

// CHECK-LABEL: yasps.attr @svs__jac : !yasps.mat<1x9xf64>
// CHECK: %[[A:.*]] = yasps.read @m::@p::@a
// CHECK: %[[S:.*]] = yasps.singular_value_sum %[[A]]
// CHECK-DAG: yasps.cofactor %[[A]]
// CHECK-DAG: yasps.det %[[A]]
// CHECK-DAG: yasps.squared_norm %[[A]]
// CHECK: yasps.attr @svs__jac__jac : !yasps.mat<9x9xf64>
// CHECK: yasps.singular_value_sum
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<3x3xf64>
      yasps.attr @svs : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<3x3xf64>
        %s = yasps.singular_value_sum %a : !yasps.mat<3x3xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@svs
  yasps.minimize [@m::@p::@a]
}

// -----

// Energies that read no target get no derivative attributes; reads of
// constants are not parameters.

// CHECK-LABEL: yasps.attr @c :
// CHECK-NOT: @c__grad
// CHECK: yasps.attr @e__jac : !yasps.mat<1x3xf64> attributes {{{.*}}yasps.params = [#yasps.param<read @m::@p::@x>]}
// CHECK: yasps.attr @e__grad : !yasps.mat<3x1xf64>
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

// -----

// JOIN of a computed attribute and UNION (paper 5.1, 5.2): the barrier's
// parameters are, per gathered vertex, those of the union member it belongs
// to, padded to the widest (12: an affine body's A and t). The affine
// vertices' Jacobian is computed once, on the vertices, and gathered; the
// soft member's is the padded identity.

// CHECK-LABEL: yasps.primitive @v(1)
// CHECK: yasps.attr @x__jac : !yasps.mat<3x12xf64> attributes {{{.*}}yasps.params = [#yasps.param<join @v2b[0] of @r::@b::@A, width 9>, #yasps.param<join @v2b[0] of @r::@b::@t, width 3>]}
// CHECK: yasps.attr @x__ujac12 : !yasps.mat<3x12xf64>
// CHECK-LABEL: yasps.mesh @s
// CHECK: yasps.attr @x__ujac12 : !yasps.mat<3x12xf64> {
// CHECK: yasps.constant dense<{{\[\[}}1.000000e+00, 0.000000e+00
// CHECK-LABEL: yasps.primitive @pp(2) dynamic
// CHECK: yasps.attr @e__jac : !yasps.mat<1x24xf64> attributes {{{.*}}yasps.params = [#yasps.param<join @p2v[0] of @w::@u::@x, width 12>, #yasps.param<join @p2v[1] of @w::@u::@x, width 12>]}
// CHECK: yasps.join @p2v(@w::@u::@x__jac) : !yasps.mat<2x36xf64>
// Affine and free vertices are linear in their parameters: the projection
// happens in reduced space, on the 6x6 Hessian of the two gathered points,
// then J^T P J brings it to the 24 parameters (paper 5.4).
// CHECK: yasps.attr @e__hess_proj : !yasps.mat<24x24xf64> attributes {{{.*}}yasps.projection = #yasps.projection<reduced>}
// CHECK: yasps.project clamp %{{.*}} : !yasps.mat<6x6xf64>
// CHECK: yasps.matmul %{{.*}}, %{{.*}} : !yasps.mat<24x6xf64>, !yasps.mat<6x24xf64> -> !yasps.mat<24x24xf64>
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

// -----

// Derivative reuse (paper 5.3): two energies gather the same computed
// positions; their Jacobian is built once, on the vertices, and both
// energies' Jacobians gather it. Linear in its parameters, the positions
// need no second Jacobian for the Hessians.

// CHECK-LABEL: yasps.primitive @v(2)
// CHECK: yasps.attr @x__jac :
// CHECK-NOT: yasps.attr @x__jac
// CHECK-LABEL: yasps.primitive @e(1)
// CHECK: yasps.attr @a__jac
// CHECK: yasps.join @e2v(@m::@v::@x__jac)
// CHECK: yasps.attr @b__jac
// CHECK: yasps.join @e2v(@m::@v::@x__jac)
// CHECK-NOT: x__jac__jac
// CHECK: yasps.minimize [@m::@b::@t]
yasps.scene @reuse {
  yasps.mesh @m {
    yasps.primitive @b(1) {
      yasps.data_attr @t : !yasps.mat<3x1xf64>
    }
    yasps.primitive @v(2) {
      yasps.const_attr @rest : !yasps.mat<3x1xf64>
      yasps.connectivity @v2b -> @m::@b arity 1
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %t = yasps.join @v2b(@m::@b::@t) : !yasps.mat<1x3xf64>
        %r = yasps.read @m::@v::@rest : !yasps.mat<3x1xf64>
        %tc = yasps.resize %t : !yasps.mat<1x3xf64> -> !yasps.mat<3x1xf64>
        %x = yasps.add %r, %tc : !yasps.mat<3x1xf64>
        yasps.yield %x : !yasps.mat<3x1xf64>
      }
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @a : !yasps.mat<1x1xf64> {
        %p = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
        %n = yasps.squared_norm %p : !yasps.mat<2x3xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
      yasps.attr @b : !yasps.mat<1x1xf64> {
        %p = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
        %s = yasps.sum %p : !yasps.mat<2x3xf64>
        %q = yasps.scale %s, %s : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %q : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@e::@a
  yasps.energy @m::@e::@b
  yasps.minimize [@m::@b::@t]
}

// -----

// A double pendulum (three angles, one 2-D position): positions are
// nonlinear in the angles, so the Hessian has a curvature term and the full
// 3x3 Hessian is projected, although the position has only 2 entries.

// CHECK-LABEL: yasps.attr @e__hess_proj : !yasps.mat<3x3xf64> attributes {{{.*}}yasps.projection = #yasps.projection<full>}
// CHECK: yasps.project clamp %{{.*}} : !yasps.mat<3x3xf64>
yasps.scene @pendulum {
  yasps.mesh @m {
    yasps.primitive @arm(1) {
      yasps.data_attr @theta : !yasps.mat<3x1xf64>
      yasps.attr @x : !yasps.mat<2x1xf64> {
        %th = yasps.read @m::@arm::@theta : !yasps.mat<3x1xf64>
        %t0 = yasps.element %th[0, 0] : !yasps.mat<3x1xf64>
        %t1 = yasps.element %th[1, 0] : !yasps.mat<3x1xf64>
        %t2 = yasps.element %th[2, 0] : !yasps.mat<3x1xf64>
        %s0 = yasps.sin %t0 : !yasps.mat<1x1xf64>
        %s1 = yasps.sin %t1 : !yasps.mat<1x1xf64>
        %c0 = yasps.cos %t2 : !yasps.mat<1x1xf64>
        %s = yasps.add %s0, %s1 : !yasps.mat<1x1xf64>
        %x = yasps.concat vertical %s, %c0 : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64> -> !yasps.mat<2x1xf64>
        yasps.yield %x : !yasps.mat<2x1xf64>
      }
    }
    yasps.primitive @bob(1) {
      yasps.connectivity @b2a -> @m::@arm arity 1
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.join @b2a(@m::@arm::@x) : !yasps.mat<1x2xf64>
        %h = yasps.element %x[0, 1] : !yasps.mat<1x2xf64>
        %n = yasps.squared_norm %x : !yasps.mat<1x2xf64>
        %e = yasps.add %h, %n : !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@bob::@e
  yasps.minimize [@m::@arm::@theta]
}
