// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@scaled,@m::@p::@twice,@m::@p::@kept projection-lanes=4" -yasps-strip-scenes -canonicalize | FileCheck %s
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@scaled" -yasps-strip-scenes -canonicalize | FileCheck %s --check-prefix=ONE

// With projection-lanes=4 the instances run in tiles of four. The body is
// emitted twice: the first copy stores each instance's matrix into a
// 9 x 4 scratch buffer (lanes innermost) and nothing else; one
// eigen-decomposition then works on vector<4xf64> values, its branches
// decided for all lanes at once (vector.reduction) and its QL loop running
// while any lane is unconverged; the second copy reads each lane's
// projected matrix back, finishes the value (the scaling by 2) and stores
// it.
// CHECK-LABEL: func.func @yasps_eval_m__p__scaled(
// CHECK-DAG: %[[FOUR:.*]] = arith.constant 4 : index
// CHECK-DAG: memref.alloca() : memref<3x3x4xf64>
// CHECK: scf.parallel (%[[TILE:.*]]) = ({{.*}}) to (%[[END:.*]]) step (%[[FOUR]])
// CHECK: %[[LEFT:.*]] = arith.subi %[[END]], %[[TILE]]
// CHECK: %[[COUNT:.*]] = arith.minui %[[LEFT]], %[[FOUR]]
// CHECK: vector.store {{.*}} : memref<9x4xf64>, vector<4xf64>
// CHECK: scf.for %[[LANE:.*]] = {{.*}} to %[[COUNT]] step
// CHECK-NOT: arith.mulf
// CHECK: memref.store {{.*}}[{{.*}}, %[[LANE]]] : memref<9x4xf64>
// CHECK-NOT: memref.store {{.*}} : memref<?xf64>
// CHECK: }
// CHECK: vector.load {{.*}} : memref<9x4xf64>, vector<4xf64>
// CHECK: vector.reduction <and>
// CHECK: math.sqrt {{.*}} : vector<4xf64>
// CHECK: scf.while
// CHECK: vector.reduction <or>
// CHECK: scf.for %[[LANE2:.*]] = {{.*}} to %[[COUNT]] step
// CHECK: memref.load {{.*}}[{{.*}}, %[[LANE2]]] : memref<9x4xf64>
// CHECK: arith.mulf
// CHECK: memref.store {{.*}} : memref<?xf64>

// Two projections per instance are not batched: one instance at a time.
// CHECK-LABEL: func.func @yasps_eval_m__p__twice(
// CHECK-NOT: vector
// CHECK: scf.parallel {{.*}} step (%c1)
// CHECK-NOT: vector
// CHECK: return

// Neither is `none`, which needs no decomposition.
// CHECK-LABEL: func.func @yasps_eval_m__p__kept(
// CHECK-NOT: vector
// CHECK-NOT: memref.alloca
// CHECK: return

// Without the option (GPU kernels): scalars only.
// ONE-LABEL: func.func @yasps_eval_m__p__scaled(
// ONE-NOT: vector
// ONE: scf.parallel {{.*}} step (%c1)
// ONE-NOT: vector
// ONE: return
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @h : !yasps.mat<3x3xf64>
      yasps.attr @scaled : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %p = yasps.project clamp %h : !yasps.mat<3x3xf64>
        %two = yasps.constant dense<2.0> : tensor<1x1xf64>
        %s = yasps.scale %p, %two : !yasps.mat<3x3xf64>, !yasps.mat<1x1xf64>
        yasps.yield %s : !yasps.mat<3x3xf64>
      }
      yasps.attr @twice : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %p = yasps.project clamp %h : !yasps.mat<3x3xf64>
        %q = yasps.project abs %h : !yasps.mat<3x3xf64>
        %s = yasps.add %p, %q : !yasps.mat<3x3xf64>
        yasps.yield %s : !yasps.mat<3x3xf64>
      }
      yasps.attr @kept : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %p = yasps.project none %h : !yasps.mat<3x3xf64>
        yasps.yield %p : !yasps.mat<3x3xf64>
      }
    }
  }
}
