// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@s3,@m::@p::@s2" -canonicalize | FileCheck %s

// The sum of signed singular values needs no SVD. A 3x3 one is the largest
// root of a quartic, found by eight Laguerre steps (one square root and one
// division each) from a start of two square roots; a 2x2 one is
// sqrt(|A|^2 + 2 det A).

// CHECK-LABEL: func.func @yasps_eval_m__p__s3(
// CHECK-COUNT-10: math.sqrt
// CHECK-NOT: math.sqrt
// CHECK: memref.store
// CHECK-LABEL: func.func @yasps_eval_m__p__s2(
// CHECK-COUNT-1: math.sqrt
// CHECK-NOT: math.sqrt
// CHECK: memref.store
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<3x3xf64>
      yasps.data_attr @b : !yasps.mat<2x2xf64>
      yasps.attr @s3 : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<3x3xf64>
        %s = yasps.singular_value_sum %a : !yasps.mat<3x3xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @s2 : !yasps.mat<1x1xf64> {
        %b = yasps.read @m::@p::@b : !yasps.mat<2x2xf64>
        %s = yasps.singular_value_sum %b : !yasps.mat<2x2xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
    }
  }
}
