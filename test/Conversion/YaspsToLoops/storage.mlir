// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@proj storage=f64 out-storage=f64" -yasps-strip-scenes -canonicalize | FileCheck %s
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@proj storage=f64 out-storage=f64 lanes=4" -yasps-strip-scenes -canonicalize | FileCheck %s --check-prefix=LANES
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@proj storage=f64" -yasps-strip-scenes -canonicalize | FileCheck %s --check-prefix=F32OUT
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@proj" -yasps-strip-scenes -canonicalize | FileCheck %s --check-prefix=OWN
// RUN: not yasps-opt %s -yasps-lower-to-loops="storage=f16" 2>&1 | FileCheck %s --check-prefix=BAD
// RUN: not yasps-opt %s -yasps-lower-to-loops="out-storage=bf16" 2>&1 | FileCheck %s --check-prefix=BADOUT

// A scene written in f32 computes in f32. With storage=f64 (what the CPU and
// GPU compilers ask for: the runtime's attribute buffers are f64) and
// out-storage=f64 (the GPU's: its assembly reads f64) every float buffer is
// f64: loads truncate to f32, the arithmetic (here a PSD projection) runs in
// f32 and the result is extended to f64 as it is stored. The eigensolver's
// tolerance is f32's unit round-off, 2^-23 (a tolerance of 2^-52 is never
// met in f32).
// CHECK-LABEL: func.func @yasps_eval_m__p__proj(
// CHECK-SAME: memref<?xf64>, %{{.*}}: memref<?xf64>)
// CHECK-DAG: arith.constant 1.1920929E-7 : f32
// CHECK: %[[X:.*]] = memref.load {{.*}} : memref<?xf64>
// CHECK: arith.truncf %[[X]] : f64 to f32
// CHECK: math.sqrt {{.*}} : f32
// CHECK: %[[R:.*]] = arith.extf {{.*}} : f32 to f64
// CHECK: memref.store %[[R]], {{.*}} : memref<?xf64>

// In lanes, the staged leaves are already f32 and a full tile's rows are
// extended a vector at a time.
// LANES-LABEL: func.func @yasps_eval_m__p__proj(
// LANES: arith.truncf {{.*}} : f64 to f32
// LANES: memref.store {{.*}} : memref<4x4xf32>
// LANES: math.sqrt {{.*}} : vector<4xf32>
// LANES: vector.shuffle
// LANES: %[[ROW:.*]] = arith.extf {{.*}} : vector<4xf32> to vector<4xf64>
// LANES: vector.store %[[ROW]], {{.*}} : memref<?xf64>, vector<4xf64>

// storage=f64 alone (the CPU's): f64 attribute buffers, and the output in the
// type computed in, stored as it is.
// F32OUT-LABEL: func.func @yasps_eval_m__p__proj(
// F32OUT-SAME: %{{.*}}: memref<?xf32>, %{{.*}}: memref<?xf64>)
// F32OUT: arith.truncf
// F32OUT-NOT: arith.extf

// Without storage=, buffers have the attributes' own type.
// OWN-LABEL: func.func @yasps_eval_m__p__proj(
// OWN-SAME: memref<?xf32>, %{{.*}}: memref<?xf32>)
// OWN-NOT: arith.truncf
// OWN-NOT: arith.extf

// BAD: storage='f16' is not f32 or f64
// BADOUT: out-storage='bf16' is not f32 or f64
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(3) {
      yasps.data_attr @h : !yasps.mat<2x2xf32>
      yasps.attr @proj : !yasps.mat<2x2xf32> {
        %h = yasps.read @m::@p::@h : !yasps.mat<2x2xf32>
        %p = yasps.project clamp %h : !yasps.mat<2x2xf32>
        yasps.yield %p : !yasps.mat<2x2xf32>
      }
    }
  }
}
