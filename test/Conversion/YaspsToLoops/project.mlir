// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@clamped,@m::@p::@kept" -yasps-strip-scenes -canonicalize | FileCheck %s

// PSD projection: two n x n scratch buffers in the entry block (not in the
// instance loop, where each alloca would grow the stack), Jacobi sweeps until
// nothing rotates, eigenvalues clamped with maximumf.
// CHECK-LABEL: func.func @yasps_eval_m__p__clamped(
// CHECK: memref.alloca() : memref<3x3xf64>
// CHECK: memref.alloca() : memref<3x3xf64>
// CHECK: scf.parallel
// CHECK: scf.for {{.*}} iter_args({{.*}}) -> (i1)
// CHECK: math.copysign
// CHECK: arith.maximumf
// CHECK: memref.store

// `none` leaves the matrix as it is: no decomposition.
// CHECK-LABEL: func.func @yasps_eval_m__p__kept(
// CHECK-NOT: memref.alloca
// CHECK-NOT: scf.for
// CHECK: return
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @h : !yasps.mat<3x3xf64>
      yasps.attr @clamped : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %p = yasps.project clamp %h : !yasps.mat<3x3xf64>
        yasps.yield %p : !yasps.mat<3x3xf64>
      }
      yasps.attr @kept : !yasps.mat<3x3xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<3x3xf64>
        %p = yasps.project none %h : !yasps.mat<3x3xf64>
        yasps.yield %p : !yasps.mat<3x3xf64>
      }
    }
  }
}
