// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@clamped,@m::@p::@kept" -yasps-strip-scenes -canonicalize | FileCheck %s

// PSD projection: scratch buffers in the entry block (not in the instance
// loop, where each alloca would grow the stack); an LDL^T test returns
// positive definite matrices as they are; otherwise Householder
// tridiagonalisation (square roots), QL iterations until the subdiagonal is
// negligible (scf.while), and eigenvalues clamped on one side of zero.
// CHECK-LABEL: func.func @yasps_eval_m__p__clamped(
// CHECK-DAG: memref.alloca() : memref<3x3xf64>
// CHECK-DAG: memref.alloca() : memref<3xf64>
// CHECK: scf.parallel
// CHECK: arith.cmpf ogt
// CHECK: scf.if {{.*}} -> (f64, f64, f64, f64, f64, f64, f64, f64, f64)
// CHECK: math.sqrt
// CHECK: scf.while
// CHECK: arith.cmpf olt
// CHECK: scf.yield

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
