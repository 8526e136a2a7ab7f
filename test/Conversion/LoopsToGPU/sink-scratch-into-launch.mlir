// RUN: yasps-opt %s -split-input-file -yasps-sink-scratch-into-launch -verify-diagnostics | FileCheck %s

// Scratch allocated in the host function's entry block and used only inside
// the launch moves to the start of the launch body (one per GPU thread).
// CHECK-LABEL: func.func @scratch
// CHECK-NEXT: %[[C1:.*]] = arith.constant 1 : index
// CHECK-NEXT: gpu.launch
// CHECK-NEXT: %[[BUF:.*]] = memref.alloca() : memref<4xf64>
// CHECK: memref.store {{.*}}, %[[BUF]]
func.func @scratch(%v: f64) {
  %buf = memref.alloca() : memref<4xf64>
  %c1 = arith.constant 1 : index
  gpu.launch blocks(%bx, %by, %bz) in (%gx = %c1, %gy = %c1, %gz = %c1)
             threads(%tx, %ty, %tz) in (%sx = %c1, %sy = %c1, %sz = %c1) {
    %c0 = arith.constant 0 : index
    memref.store %v, %buf[%c0] : memref<4xf64>
    gpu.terminator
  }
  return
}

// -----

// A buffer the host also uses cannot be given to the threads.
func.func @shared(%v: f64) -> f64 {
  // expected-error @below {{kernel scratch buffer is used outside one gpu.launch}}
  %buf = memref.alloca() : memref<f64>
  %c1 = arith.constant 1 : index
  gpu.launch blocks(%bx, %by, %bz) in (%gx = %c1, %gy = %c1, %gz = %c1)
             threads(%tx, %ty, %tz) in (%sx = %c1, %sy = %c1, %sz = %c1) {
    memref.store %v, %buf[] : memref<f64>
    gpu.terminator
  }
  %r = memref.load %buf[] : memref<f64>
  return %r : f64
}
