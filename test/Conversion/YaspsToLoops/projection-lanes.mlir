// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@small,@m::@p::@large lanes=4 projection-lanes=8" -yasps-strip-scenes -canonicalize | FileCheck %s
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@small lanes=4" -yasps-strip-scenes -canonicalize | FileCheck %s --check-prefix=SAME

// Kernels that project a matrix of at most 9x9 run projection-lanes
// instances at a time, two vectors' worth here: the eigensolver's chains
// of square roots and divisions overlap. A 10x10 projection keeps `lanes`
// (its compile time grows with the width, its gain shrinks). Without the option every
// kernel has `lanes`.
// CHECK-LABEL: func.func @yasps_eval_m__p__small(
// CHECK: %[[EIGHT:.*]] = arith.constant 8 : index
// CHECK: scf.parallel ({{.*}}) = ({{.*}}) to ({{.*}}) step (%[[EIGHT]])
// CHECK: math.sqrt {{.*}} : vector<8xf64>
// CHECK-LABEL: func.func @yasps_eval_m__p__large(
// CHECK-NOT: vector<8xf64>
// CHECK: math.sqrt {{.*}} : vector<4xf64>

// SAME-LABEL: func.func @yasps_eval_m__p__small(
// SAME-NOT: vector<8xf64>
// SAME: math.sqrt {{.*}} : vector<4xf64>
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @h : !yasps.mat<3x3xf64>
      yasps.data_attr @g : !yasps.mat<10x10xf64>
      yasps.attr @small : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %p = yasps.project clamp %h : !yasps.mat<3x3xf64>
        yasps.yield %p : !yasps.mat<3x3xf64>
      }
      yasps.attr @large : !yasps.mat<10x10xf64> {
        %g = yasps.read @m::@p::@g : !yasps.mat<10x10xf64>
        %p = yasps.project clamp %g : !yasps.mat<10x10xf64>
        yasps.yield %p : !yasps.mat<10x10xf64>
      }
    }
  }
}
