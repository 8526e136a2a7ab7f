// RUN: yasps-opt %s -pass-pipeline='builtin.module(gpu.module(yasps-precise-gpu-sqrt))' | FileCheck %s
// RUN: yasps-opt %s -pass-pipeline='builtin.module(gpu.module(yasps-precise-gpu-sqrt,convert-gpu-to-nvvm))' | FileCheck %s --check-prefix=NVVM

// f32 square roots become the correctly rounded PTX instruction, which
// convert-gpu-to-nvvm keeps; f64 ones are left to libdevice's __nv_sqrt,
// which rounds correctly. Without the pass, f32 would call __nv_sqrtf
// (sqrt.approx.f32 unless __CUDA_PREC_SQRT is reflected).
// CHECK-LABEL: gpu.func @roots
// CHECK: llvm.inline_asm "sqrt.rn.f32 $0, $1;", "=f,f" %{{.*}} : (f32) -> f32
// CHECK-NOT: math.sqrt {{.*}} : f32
// CHECK: math.sqrt %{{.*}} : f64

// NVVM-NOT: __nv_sqrtf
// NVVM: llvm.inline_asm "sqrt.rn.f32 $0, $1;"
// NVVM: llvm.call @__nv_sqrt(
gpu.module @kernels {
  gpu.func @roots(%a: f32, %b: f64, %out: memref<2xf64>) kernel {
    %c0 = arith.constant 0 : index
    %c1 = arith.constant 1 : index
    %ra = math.sqrt %a : f32
    %rb = math.sqrt %b : f64
    %wide = arith.extf %ra : f32 to f64
    memref.store %wide, %out[%c0] : memref<2xf64>
    memref.store %rb, %out[%c1] : memref<2xf64>
    gpu.return
  }
}
