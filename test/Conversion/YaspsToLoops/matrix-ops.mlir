// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@inv" -canonicalize | FileCheck %s

// Matrix-level ops are expanded: a 2x2 inverse is the adjugate over the
// determinant.

// CHECK-LABEL: func.func @yasps_eval_m__p__inv(
// CHECK: %[[D:.*]] = arith.addf
// CHECK: %[[R:.*]] = arith.divf %{{.*}}, %[[D]] : f64
// CHECK: arith.mulf %{{.*}}, %[[R]]
// CHECK-COUNT-4: memref.store
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<2x2xf64>
      yasps.attr @inv : !yasps.mat<2x2xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<2x2xf64>
        %i = yasps.inverse %a : !yasps.mat<2x2xf64>
        yasps.yield %i : !yasps.mat<2x2xf64>
      }
    }
  }
}
