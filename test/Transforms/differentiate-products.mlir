// RUN: yasps-opt %s -split-input-file -yasps-differentiate -canonicalize -cse | FileCheck %s

// Squares: the product rule of s * s is 2 s s' (one product per direction),
// not s' s + s s' (two products that CSE cannot merge).
// CHECK-LABEL: yasps.attr @square__jac :
// CHECK: %[[TWO:.*]] = yasps.constant dense<2.000000e+00>
// CHECK: %[[N:.*]] = yasps.norm
// CHECK: %[[P:.*]] = yasps.scale %[[N]], %{{.*}}
// CHECK-NEXT: yasps.scale %[[P]], %[[TWO]]
// CHECK-NOT: yasps.scale %{{.*}}, %[[N]] :
// CHECK: yasps.yield
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<2x1xf64>
      yasps.attr @square : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<2x1xf64>
        %s = yasps.norm %x : !yasps.mat<2x1xf64>
        %sq = yasps.scale %s, %s : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %sq : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@square
  yasps.minimize [@m::@p::@x]
}

// -----

// Quotients and norms: every direction multiplies by one shared reciprocal
// (a single pow(s, -1), lowered to one division) instead of dividing. The
// second derivative of the reciprocal is -(1/s)^2 s', a product, not a
// pow(s, -2) call.
// CHECK-LABEL: yasps.attr @length__jac__jac :
// CHECK-COUNT-1: yasps.pow
// CHECK-NOT: yasps.pow
// CHECK-NOT: yasps.div
// CHECK: yasps.yield
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @length : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x1xf64>
        %n = yasps.norm %x : !yasps.mat<3x1xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@length
  yasps.minimize [@m::@p::@x]
}
