// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@d,@m::@p::@v" -yasps-strip-scenes -canonicalize -cse | FileCheck %s

// Derivative kernels (attributes with yasps.params) move negations
// outwards: -a * b becomes -(a * b) and x * -1 becomes -x, so that the
// product a * b is computed once for entries of either sign (the +-K
// blocks of Hessians of differences). Each rewrite is exact in IEEE
// arithmetic.
// CHECK-LABEL: func.func @yasps_eval_m__p__d(
// CHECK: %[[A:.*]] = memref.load
// CHECK: %[[B:.*]] = memref.load
// CHECK: %[[P:.*]] = arith.mulf %[[A]], %[[B]]
// CHECK-NOT: arith.mulf
// CHECK: %[[N:.*]] = arith.negf %[[P]]
// CHECK-NOT: arith.mulf
// CHECK: memref.store %[[N]]
// CHECK: memref.store %[[P]]

// Value kernels keep the operations as written.
// CHECK-LABEL: func.func @yasps_eval_m__p__v(
// CHECK: arith.negf
// CHECK: arith.mulf
// CHECK: arith.mulf
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<1x1xf64>
      yasps.data_attr @b : !yasps.mat<1x1xf64>
      yasps.attr @d : !yasps.mat<2x1xf64> attributes {yasps.params = []} {
        %a = yasps.read @m::@p::@a : !yasps.mat<1x1xf64>
        %b = yasps.read @m::@p::@b : !yasps.mat<1x1xf64>
        %na = yasps.neg %a : !yasps.mat<1x1xf64>
        %p = yasps.elementwise_mul %na, %b : !yasps.mat<1x1xf64>
        %q = yasps.elementwise_mul %a, %b : !yasps.mat<1x1xf64>
        %c = yasps.concat vertical %p, %q : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64> -> !yasps.mat<2x1xf64>
        yasps.yield %c : !yasps.mat<2x1xf64>
      }
      yasps.attr @v : !yasps.mat<2x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<1x1xf64>
        %b = yasps.read @m::@p::@b : !yasps.mat<1x1xf64>
        %na = yasps.neg %a : !yasps.mat<1x1xf64>
        %p = yasps.elementwise_mul %na, %b : !yasps.mat<1x1xf64>
        %q = yasps.elementwise_mul %a, %b : !yasps.mat<1x1xf64>
        %c = yasps.concat vertical %p, %q : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64> -> !yasps.mat<2x1xf64>
        yasps.yield %c : !yasps.mat<2x1xf64>
      }
    }
  }
}
