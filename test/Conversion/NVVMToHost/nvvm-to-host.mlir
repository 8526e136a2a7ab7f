// RUN: yasps-opt %s -split-input-file -verify-diagnostics -pass-pipeline='builtin.module(gpu.module(yasps-nvvm-to-host))' | FileCheck %s

// The kernel's body reads its ids from the thread context (one more
// argument); a new entry point of the kernel's name loads each parameter
// through cuLaunchKernel's array of pointers. libdevice calls become the C
// library's, and the correctly rounded f32 square root llvm.intr.sqrt.
// CHECK-LABEL: gpu.module @kernels
// CHECK-DAG: llvm.func @exp(f64) -> f64
// CHECK-DAG: llvm.func @sqrtf(f32) -> f32
// CHECK: llvm.func internal @scale__body(%[[N:.*]]: i64, %[[P:.*]]: !llvm.ptr, %[[T:.*]]: !llvm.ptr)
// CHECK: %[[CTA:.*]] = llvm.getelementptr inbounds %[[T]][6] : (!llvm.ptr) -> !llvm.ptr, i32
// CHECK: llvm.load %[[CTA]] : !llvm.ptr -> i32
// CHECK: %[[NTID:.*]] = llvm.getelementptr inbounds %[[T]][3] : (!llvm.ptr) -> !llvm.ptr, i32
// CHECK: llvm.load %[[NTID]] : !llvm.ptr -> i32
// CHECK: %[[TID:.*]] = llvm.getelementptr inbounds %[[T]][0] : (!llvm.ptr) -> !llvm.ptr, i32
// CHECK: llvm.load %[[TID]] : !llvm.ptr -> i32
// CHECK-NOT: nvvm.
// CHECK: llvm.call @exp
// CHECK: llvm.intr.sqrt(%{{.*}}) : (f32) -> f32
// CHECK-NOT: llvm.inline_asm
// CHECK: llvm.call @sqrtf
// CHECK: llvm.func @scale(%[[PARAMS:.*]]: !llvm.ptr, %[[THREAD:.*]]: !llvm.ptr) attributes {gpu.kernel}
// CHECK: %[[S0:.*]] = llvm.getelementptr inbounds %[[PARAMS]][0] : (!llvm.ptr) -> !llvm.ptr, !llvm.ptr
// CHECK: %[[A0:.*]] = llvm.load %[[S0]] : !llvm.ptr -> !llvm.ptr
// CHECK: %[[V0:.*]] = llvm.load %[[A0]] : !llvm.ptr -> i64
// CHECK: %[[S1:.*]] = llvm.getelementptr inbounds %[[PARAMS]][1] : (!llvm.ptr) -> !llvm.ptr, !llvm.ptr
// CHECK: %[[A1:.*]] = llvm.load %[[S1]] : !llvm.ptr -> !llvm.ptr
// CHECK: %[[V1:.*]] = llvm.load %[[A1]] : !llvm.ptr -> !llvm.ptr
// CHECK: llvm.call @scale__body(%[[V0]], %[[V1]], %[[THREAD]])
// CHECK: llvm.return
gpu.module @kernels {
  llvm.func @__nv_exp(f64) -> f64
  llvm.func @__nv_sqrtf(f32) -> f32
  llvm.func @scale(%n: i64, %out: !llvm.ptr) attributes {gpu.kernel, nvvm.kernel} {
    %b = nvvm.read.ptx.sreg.ctaid.x : i32
    %w = nvvm.read.ptx.sreg.ntid.x : i32
    %t = nvvm.read.ptx.sreg.tid.x : i32
    %bw = llvm.mul %b, %w : i32
    %i32 = llvm.add %bw, %t : i32
    %i = llvm.sext %i32 : i32 to i64
    %in = llvm.icmp "ult" %i, %n : i64
    llvm.cond_br %in, ^body, ^done
  ^body:
    %f = llvm.sitofp %i : i64 to f64
    %e = llvm.call @__nv_exp(%f) : (f64) -> f64
    %h = llvm.fptrunc %e : f64 to f32
    %r = llvm.inline_asm has_side_effects "sqrt.rn.f32 $0, $1;", "=f,f" %h : (f32) -> f32
    %a = llvm.call @__nv_sqrtf(%r) : (f32) -> f32
    %d = llvm.fpext %a : f32 to f64
    %p = llvm.getelementptr %out[%i] : (!llvm.ptr, i64) -> !llvm.ptr, f64
    llvm.store %d, %p : f64, !llvm.ptr
    llvm.br ^done
  ^done:
    llvm.return
  }
}

// -----

// What the host cannot run is refused, not miscompiled.
gpu.module @barrier {
  llvm.func @k() attributes {gpu.kernel, nvvm.kernel} {
    // expected-error @+1 {{no host equivalent of nvvm.barrier0}}
    nvvm.barrier0
    llvm.return
  }
}

// -----

gpu.module @shared {
  // expected-error @+1 {{host images have no GPU shared or constant memory}}
  llvm.mlir.global internal @tile() {addr_space = 3 : i32} : !llvm.array<4 x f64>
  llvm.func @k() attributes {gpu.kernel, nvvm.kernel} {
    llvm.return
  }
}

// -----

gpu.module @libdevice {
  // expected-error @+1 {{no host math function for __nv_rsqrt}}
  llvm.func @__nv_rsqrt(f64) -> f64
  llvm.func @k() attributes {gpu.kernel, nvvm.kernel} {
    llvm.return
  }
}

// -----

gpu.module @asm {
  llvm.func @k(%x: f32) attributes {gpu.kernel, nvvm.kernel} {
    // expected-error @+1 {{inline assembly the host cannot run: rsqrt.approx.f32 $0, $1;}}
    %r = llvm.inline_asm "rsqrt.approx.f32 $0, $1;", "=f,f" %x : (f32) -> f32
    llvm.return
  }
}
