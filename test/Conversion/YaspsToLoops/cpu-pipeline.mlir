// The pipeline Python runs for the CPU (docs/passes.md): kernels, then the
// LLVM dialect. Nothing but LLVM dialect ops may remain.
// RUN: yasps-opt %s -yasps-lower-to-loops -yasps-strip-scenes -canonicalize -cse \
// RUN:   -convert-scf-to-cf -convert-to-llvm -reconcile-unrealized-casts | FileCheck %s

// CHECK: llvm.func @yasps_eval_m__p__e(
// CHECK: llvm.intr.atan2
// CHECK: llvm.intr.sqrt
// CHECK-NOT: {{ (scf|arith|math|memref|func|cf)\.}}
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<2x1xf64>
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<2x1xf64>
        %a = yasps.element %x[0, 0] : !yasps.mat<2x1xf64>
        %b = yasps.element %x[1, 0] : !yasps.mat<2x1xf64>
        %t = yasps.atan2 %a, %b : !yasps.mat<1x1xf64>
        %n = yasps.norm %x : !yasps.mat<2x1xf64>
        %s = yasps.add %t, %n : !yasps.mat<1x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
}
