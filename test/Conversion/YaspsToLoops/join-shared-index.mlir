// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@e::@s" | FileCheck %s
// JOINs through one connectivity at one instance read its index once, and
// a computed source gathered twice (here directly and through the computed
// @parent) is evaluated once: a chain of JOINs of computed attributes (a
// kinematic tree's transforms and their Jacobians) otherwise re-evaluates
// every ancestor once per path, 3^depth times.
// CHECK-LABEL: func.func @yasps_eval_m__e__s
// CHECK:         memref.load %{{.*}} : memref<?xi32>
// CHECK:         %[[X:.*]] = memref.load %{{.*}} : memref<?xf64>
// CHECK-NEXT:    arith.mulf %[[X]], %[[X]] : f64
// CHECK-NOT:     memref.load
// CHECK-NOT:     arith.mulf
// CHECK:         memref.store
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(2) {
      yasps.data_attr @x : !yasps.mat<1x1xf64>
      yasps.attr @y : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@v::@x : !yasps.mat<1x1xf64>
        %y = yasps.scale %x, %x : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %y : !yasps.mat<1x1xf64>
      }
    }
    yasps.primitive @e(1) {
      yasps.connectivity @c -> @m::@v arity 1
      yasps.attr @parent : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@v::@y) : !yasps.mat<1x1xf64>
        yasps.yield %j : !yasps.mat<1x1xf64>
      }
      yasps.attr @s : !yasps.mat<1x1xf64> {
        %a = yasps.join @c(@m::@v::@y) : !yasps.mat<1x1xf64>
        %b = yasps.join @c(@m::@v::@x) : !yasps.mat<1x1xf64>
        %p = yasps.read @m::@e::@parent : !yasps.mat<1x1xf64>
        %ab = yasps.add %a, %b : !yasps.mat<1x1xf64>
        %s = yasps.add %ab, %p : !yasps.mat<1x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
    }
  }
}
