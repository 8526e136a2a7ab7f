// RUN: yasps-opt %s -yasps-inline-reads -cse -split-input-file | FileCheck %s

// A chain of computed attributes collapses onto the stored attributes; stored
// reads (data, constants) and JOINs stay.

yasps.scene @s {
  yasps.const_attr @scale : !yasps.mat<1x1xf64>
  yasps.mesh @m {
    yasps.primitive @v(3) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @sq : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@v::@x : !yasps.mat<3x1xf64>
        %d = yasps.dot %x, %x : !yasps.mat<3x1xf64>
        yasps.yield %d : !yasps.mat<1x1xf64>
      }
      yasps.attr @scaled : !yasps.mat<1x1xf64> {
        %sq = yasps.read @m::@v::@sq : !yasps.mat<1x1xf64>
        %k = yasps.read @scale : !yasps.mat<1x1xf64>
        %r = yasps.scale %sq, %k : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %r : !yasps.mat<1x1xf64>
      }
      // CHECK-LABEL: yasps.attr @twice
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@v::@x
      // CHECK-NEXT: %[[D:.*]] = yasps.dot %[[X]], %[[X]]
      // CHECK-NEXT: %[[K:.*]] = yasps.read @scale
      // CHECK-NEXT: %[[S:.*]] = yasps.scale %[[D]], %[[K]]
      // CHECK-NEXT: %[[R:.*]] = yasps.add %[[S]], %[[S]]
      // CHECK-NEXT: yasps.yield %[[R]]
      yasps.attr @twice : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@v::@scaled : !yasps.mat<1x1xf64>
        %b = yasps.read @m::@v::@scaled : !yasps.mat<1x1xf64>
        %r = yasps.add %a, %b : !yasps.mat<1x1xf64>
        yasps.yield %r : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// JOIN attributes are inlined as JOIN ops; their sources stay symbolic.

yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(3) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(2) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @ends : !yasps.mat<2x3xf64> {
        %0 = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
      // CHECK-LABEL: yasps.attr @first
      // CHECK-NEXT: %[[J:.*]] = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
      // CHECK-NEXT: %[[R:.*]] = yasps.row %[[J]][0]
      // CHECK-NEXT: yasps.yield %[[R]]
      yasps.attr @first : !yasps.mat<1x3xf64> {
        %0 = yasps.read @m::@e::@ends : !yasps.mat<2x3xf64>
        %1 = yasps.row %0[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        yasps.yield %1 : !yasps.mat<1x3xf64>
      }
    }
  }
}
