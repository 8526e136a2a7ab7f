// RUN: yasps-opt %s -yasps-lower-to-loops -yasps-strip-scenes -canonicalize -cse -yasps-count-ops | FileCheck %s

// x.x + log(x0 / x1): 3 multiplications, 3 additions (two in the dot), 1
// division, 1 log.
// CHECK: func.func @yasps_eval_m__p__e
// CHECK-SAME: yasps.op_counts = {add = 3 : i64, div = 1 : i64, math = 1 : i64, mul = 3 : i64}
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x1xf64>
        %d = yasps.dot %x, %x : !yasps.mat<3x1xf64>
        %a = yasps.element %x[0, 0] : !yasps.mat<3x1xf64>
        %b = yasps.element %x[1, 0] : !yasps.mat<3x1xf64>
        %q = yasps.div %a, %b : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %l = yasps.log %q : !yasps.mat<1x1xf64>
        %e = yasps.add %d, %l : !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
}
