// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@proj" -yasps-strip-scenes -canonicalize -yasps-loops-to-gpu | FileCheck %s
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@proj" -yasps-strip-scenes -canonicalize -yasps-loops-to-gpu="chips=sm_90 format=isa" | FileCheck %s --check-prefix=PTX

// The instance loop becomes blocks of 128 threads; the host function keeps
// only the launch, whose operands are its own arguments and constants (the
// runtime's launch ABI). The projection's scratch is allocated in the
// kernel, per thread.
// CHECK-LABEL: func.func @yasps_eval_m__p__proj(%arg0: index, %arg1: index, %arg2: memref<?xf64>, %arg3: memref<?xf64>)
// CHECK-NOT: memref.alloca
// CHECK: gpu.launch_func @yasps_eval_m__p__proj_kernel::@yasps_eval_m__p__proj_kernel
// CHECK-SAME: threads in (%c128
// CHECK-SAME: args(%c128 : index, %arg0 : index, %arg1 : index, %arg3 : memref<?xf64>, %arg2 : memref<?xf64>)
// CHECK: gpu.module @yasps_eval_m__p__proj_kernel
// CHECK: gpu.func @yasps_eval_m__p__proj_kernel(
// CHECK-SAME: kernel
// CHECK-DAG: gpu.block_id x
// CHECK-DAG: gpu.thread_id x
// CHECK-DAG: memref.alloca() : memref<2x2xf64>
// CHECK: arith.cmpi ult
// CHECK: scf.if

// Serialised for sm_90 as PTX (format=bin gives a cubin through ptxas).
// PTX: gpu.binary @yasps_eval_m__p__proj_kernel [#gpu.object<#nvvm.target<O = 3, chip = "sm_90">
// PTX-SAME: .target sm_90
// PTX-SAME: .entry yasps_eval_m__p__proj_kernel(
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @h : !yasps.mat<2x2xf64>
      yasps.attr @proj : !yasps.mat<2x2xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<2x2xf64>
        %p = yasps.project clamp %h : !yasps.mat<2x2xf64>
        yasps.yield %p : !yasps.mat<2x2xf64>
      }
    }
  }
}
