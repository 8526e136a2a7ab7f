// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@scaled,@m::@p::@twice,@m::@p::@cheap lanes=4" -yasps-strip-scenes -canonicalize | FileCheck %s
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@scaled" -yasps-strip-scenes -canonicalize | FileCheck %s --check-prefix=ONE

// With lanes=4 the instances run in tiles of four. A first loop over the
// tile stages each instance's leaves (here the 9 entries of @h) in a 9 x 4
// buffer, lanes innermost, after zeroing it for a partial last tile; the
// arithmetic then runs once on vector<4xf64> values: the PSD projection's
// eigensolver (its branches decided for all lanes at once with
// vector.reduction, its QL loop running while any lane is unconverged) and
// the scaling by 2; a full tile's results are transposed in registers and
// stored four entries at a time, a partial one lane by lane.
// CHECK-LABEL: func.func @yasps_eval_m__p__scaled(
// CHECK-DAG: %[[FOUR:.*]] = arith.constant 4 : index
// CHECK: scf.parallel (%[[TILE:.*]]) = ({{.*}}) to (%[[END:.*]]) step (%[[FOUR]])
// CHECK: %[[LEFT:.*]] = arith.subi %[[END]], %[[TILE]]
// CHECK: %[[COUNT:.*]] = arith.minui %[[LEFT]], %[[FOUR]]
// CHECK: vector.store {{.*}}, %[[STAGE:[a-z_0-9]+]][{{.*}}] : memref<9x4xf64>, vector<4xf64>
// CHECK: scf.for %[[LANE:.*]] = {{.*}} to %[[COUNT]] step
// CHECK-NOT: arith.mulf
// CHECK: memref.store {{.*}}, %[[STAGE]][{{.*}}, %[[LANE]]] : memref<9x4xf64>
// CHECK-NOT: memref.store {{.*}} : memref<?xf64>
// CHECK: }
// While the arithmetic runs, the lines of the next tile's results are
// fetched for writing (a full next tile only: 9 x 4 f64 entries, 8 per line).
// CHECK: %[[NEXT:.*]] = arith.addi %[[TILE]], %c8
// CHECK: %[[INSIDE:.*]] = arith.cmpi ule, %[[NEXT]], %[[END]]
// CHECK: scf.if %[[INSIDE]] {
// CHECK: scf.for %[[LINE:.*]] = %c0 to %c36 step %c8 {
// CHECK: memref.prefetch %{{.*}}[%{{.*}}], write, locality<3>, data : memref<?xf64>
// CHECK: vector.load %[[STAGE]]{{.*}} : memref<9x4xf64>, vector<4xf64>
// CHECK: vector.reduction <and>
// CHECK: math.sqrt {{.*}} : vector<4xf64>
// CHECK: scf.while
// CHECK: vector.reduction <or>
// CHECK: arith.mulf {{.*}} : vector<4xf64>
// CHECK: %[[FULL:.*]] = arith.cmpi eq, %[[COUNT]], %[[FOUR]]
// CHECK: scf.if %[[FULL]] {
// CHECK: vector.shuffle
// CHECK: vector.store {{.*}} : memref<?xf64>, vector<4xf64>
// CHECK: } else {
// CHECK: scf.for %[[LANE2:.*]] = {{.*}} to %[[COUNT]] step
// CHECK: memref.load {{.*}}[{{.*}}, %[[LANE2]]] : memref<9x4xf64>
// CHECK: memref.store {{.*}} : memref<?xf64>

// Two projections per instance run in lanes too.
// CHECK-LABEL: func.func @yasps_eval_m__p__twice(
// CHECK: scf.parallel {{.*}} step (%c4)
// CHECK-COUNT-2: scf.while

// Little arithmetic per result (a scaling): staging would cost more than
// the lanes save, so one instance at a time.
// CHECK-LABEL: func.func @yasps_eval_m__p__cheap(
// CHECK-NOT: vector
// CHECK: scf.parallel {{.*}} step (%c1)
// CHECK-NOT: vector
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
      yasps.attr @cheap : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %two = yasps.constant dense<2.0> : tensor<1x1xf64>
        %s = yasps.scale %h, %two : !yasps.mat<3x3xf64>, !yasps.mat<1x1xf64>
        yasps.yield %s : !yasps.mat<3x3xf64>
      }
    }
  }
}
