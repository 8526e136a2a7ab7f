// RUN: yasps-opt %s -split-input-file -yasps-lower-to-loops -yasps-strip-scenes -canonicalize -cse | FileCheck %s

// A stored attribute read per instance, a scene constant broadcast (instance
// 0), and entry-wise scalar code; one parallel loop over [begin, end).

// CHECK-LABEL: func.func @yasps_eval_m__v__e(
// CHECK-SAME: %[[BEGIN:.*]]: index, %[[END:.*]]: index, %[[OUT:.*]]: memref<?xf64>, %[[X:.*]]: memref<?xf64>, %[[K:.*]]: memref<?xf64>)
// CHECK-SAME: yasps.kernel_args = [#yasps.kernel_arg<out @m::@v::@e>, #yasps.kernel_arg<attr @m::@v::@x>, #yasps.kernel_arg<attr @k>]
// CHECK-SAME: yasps.kernel_of = @m::@v::@e
// CHECK-DAG: %[[C0:.*]] = arith.constant 0 : index
// CHECK-DAG: %[[C3:.*]] = arith.constant 3 : index
// CHECK: scf.parallel (%[[I:.*]]) = (%[[BEGIN]]) to (%[[END]])
// CHECK: %[[BASE:.*]] = arith.muli %[[I]], %[[C3]]
// CHECK: %[[X0:.*]] = memref.load %[[X]][%[[BASE]]]
// CHECK: memref.load %[[K]][%[[C0]]]
// CHECK: arith.mulf
// CHECK: math.log
// CHECK: memref.store %{{.*}}, %[[OUT]][%[[I]]]
// CHECK-NOT: yasps.
yasps.scene @s {
  yasps.const_attr @k : !yasps.mat<1x1xf64>
  yasps.mesh @m {
    yasps.primitive @v(10) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@v::@x : !yasps.mat<3x1xf64>
        %k = yasps.read @k : !yasps.mat<1x1xf64>
        %d = yasps.dot %x, %x : !yasps.mat<3x1xf64>
        %s = yasps.scale %d, %k : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %l = yasps.log %s : !yasps.mat<1x1xf64>
        yasps.yield %l : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@v::@e
}

// -----

// A JOIN gathers through the connectivity's int32 indices and evaluates the
// source (a computed attribute, not stored) at the gathered instances.

// CHECK-LABEL: func.func @yasps_eval_m__e__len(
// CHECK-SAME: %{{.*}}: memref<?xf64>, %[[CONN:.*]]: memref<?xi32>, %[[X:.*]]: memref<?xf64>)
// CHECK-SAME: #yasps.kernel_arg<conn @m::@e::@e2v>, #yasps.kernel_arg<attr @m::@v::@x>
// CHECK: scf.parallel (%[[I:.*]]) =
// CHECK: %[[B:.*]] = arith.muli %[[I]], %c2
// CHECK: %[[J0:.*]] = memref.load %[[CONN]][%[[B]]] : memref<?xi32>
// CHECK: %[[I0:.*]] = arith.index_cast %[[J0]] : i32 to index
// CHECK: %[[XB0:.*]] = arith.muli %[[I0]], %c3
// CHECK: memref.load %[[X]][%[[XB0]]]
// CHECK: %[[B1:.*]] = arith.addi %[[B]], %c1
// CHECK: memref.load %[[CONN]][%[[B1]]] : memref<?xi32>
// CHECK: math.sqrt
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(4) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @twice : !yasps.mat<3x1xf64> {
        %x = yasps.read @m::@v::@x : !yasps.mat<3x1xf64>
        %y = yasps.add %x, %x : !yasps.mat<3x1xf64>
        yasps.yield %y : !yasps.mat<3x1xf64>
      }
    }
    yasps.primitive @e(2) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @len : !yasps.mat<1x1xf64> {
        %p = yasps.join @e2v(@m::@v::@twice) : !yasps.mat<2x3xf64>
        %a = yasps.row %p[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %b = yasps.row %p[1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %d = yasps.sub %b, %a : !yasps.mat<1x3xf64>
        %n = yasps.norm %d : !yasps.mat<1x3xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@e::@len
}

// -----

// A UNION decodes the union index with the union's i64 prefix offsets: member
// 0 below offsets[1], member 1 below offsets[2], member 2 otherwise.

// CHECK-LABEL: func.func @yasps_eval_m__u__x(
// CHECK-SAME: #yasps.kernel_arg<offsets @m::@u>, #yasps.kernel_arg<attr @m::@a::@x>, #yasps.kernel_arg<attr @m::@b::@x>, #yasps.kernel_arg<attr @m::@c::@x>
// CHECK: scf.parallel (%[[I:.*]]) =
// CHECK: %[[O1:.*]] = memref.load %[[OFF:.*]][%c1] : memref<?xi64>
// CHECK: %[[O1I:.*]] = arith.index_cast %[[O1]] : i64 to index
// CHECK: %[[IN0:.*]] = arith.cmpi ult, %[[I]], %[[O1I]]
// CHECK: scf.if %[[IN0]] -> (f64)
// CHECK:   memref.load %[[OFF]][%c0]
// CHECK:   arith.subi %[[I]]
// CHECK: } else {
// CHECK:   memref.load %[[OFF]][%c2]
// CHECK:   arith.cmpi ult
// CHECK:   scf.if
// CHECK: memref.store
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @a(2) {
      yasps.data_attr @x : !yasps.mat<1x1xf64>
    }
    yasps.primitive @b(3) {
      yasps.const_attr @x : !yasps.mat<1x1xf64>
    }
    yasps.primitive @c(1) {
      yasps.data_attr @x : !yasps.mat<1x1xf64>
    }
    yasps.primitive_union @u [@m::@a, @m::@b, @m::@c] {
      yasps.attr @x : !yasps.mat<1x1xf64> {
        %0 = yasps.union @x : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@u::@x
}

