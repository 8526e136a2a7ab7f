// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@v::@idx" -yasps-strip-scenes -canonicalize | FileCheck %s

// yasps.dof_index: the target's first DoF comes from the "dof_offsets"
// buffer (one i64 per target of yasps.minimize; @m::@v::@x is the second),
// then offset + instance * 3 + entry + 1, as floats.
// CHECK-LABEL: func.func @yasps_eval_m__v__idx(
// CHECK-SAME: %{{.*}}: memref<?xf64>, %[[OFFSETS:.*]]: memref<?xi64>)
// CHECK-SAME: yasps.kernel_args = [#yasps.kernel_arg<out @m::@v::@idx>, #yasps.kernel_arg<dof_offsets @s>]
// CHECK-SAME: yasps.kernel_shape = array<i64: 3, 1>
// CHECK: scf.parallel (%[[I:.*]]) =
// CHECK: %[[RAW:.*]] = memref.load %[[OFFSETS]][%c1] : memref<?xi64>
// CHECK: %[[FIRST:.*]] = arith.index_cast %[[RAW]] : i64 to index
// CHECK: %[[STRIDE:.*]] = arith.muli %[[I]], %c3
// CHECK: %[[BASE:.*]] = arith.addi %[[FIRST]], %[[STRIDE]]
// CHECK: %[[E0:.*]] = arith.addi %[[BASE]], %c1
// CHECK: %[[N0:.*]] = arith.index_cast %[[E0]] : index to i64
// CHECK: arith.sitofp %[[N0]] : i64 to f64
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(4) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @idx : !yasps.mat<3x1xf64> {
        %i = yasps.dof_index @m::@v::@x : !yasps.mat<3x1xf64>
        yasps.yield %i : !yasps.mat<3x1xf64>
      }
    }
    yasps.primitive @b(1) {
      yasps.data_attr @t : !yasps.mat<2x1xf64>
    }
  }
  yasps.minimize [@m::@b::@t, @m::@v::@x]
}
