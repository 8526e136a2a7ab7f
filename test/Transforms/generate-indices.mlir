// RUN: yasps-opt %s -yasps-differentiate -yasps-generate-indices -canonicalize -cse | FileCheck %s

// Placement indices (paper A.3) of the point-point energy over a UNION of
// affine-body vertices (12 parameters: A and t of the gathered body) and
// free vertices (3, padded with zeros to the slot's 12).
// CHECK-LABEL: yasps.primitive @b(1)
// CHECK: yasps.attr @A__dofs : !yasps.mat<9x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @r::@b::@A>} {
// CHECK-NEXT: yasps.dof_index @r::@b::@A : !yasps.mat<9x1xf64>
// CHECK: yasps.attr @t__dofs : !yasps.mat<3x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @r::@b::@t>} {
// CHECK-NEXT: yasps.dof_index @r::@b::@t : !yasps.mat<3x1xf64>
// An affine vertex's indices are its body's, gathered once per source.
// CHECK-LABEL: yasps.primitive @v(1)
// CHECK: yasps.attr @x__udofs12 : !yasps.mat<12x1xf64> {
// CHECK-NEXT: yasps.read @r::@v::@x__dofs : !yasps.mat<12x1xf64>
// CHECK: yasps.attr @x__dofs : !yasps.mat<12x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @r::@v::@x>} {
// CHECK: yasps.join @v2b(@r::@b::@A__dofs) : !yasps.mat<1x9xf64>
// CHECK: yasps.join @v2b(@r::@b::@t__dofs) : !yasps.mat<1x3xf64>
// CHECK: yasps.concat vertical {{.*}} -> !yasps.mat<12x1xf64>
// A free vertex fills 3 of the 12 entries; 0 marks the padding.
// CHECK-LABEL: yasps.mesh @s
// CHECK: yasps.attr @x__udofs12 : !yasps.mat<12x1xf64> {
// CHECK-NEXT: yasps.constant dense<0.000000e+00> : tensor<9x1xf64>
// CHECK-NEXT: yasps.read @s::@v::@x__dofs : !yasps.mat<3x1xf64>
// CHECK-NEXT: yasps.concat vertical
// CHECK: yasps.attr @x__dofs : !yasps.mat<3x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @s::@v::@x>} {
// CHECK-NEXT: yasps.dof_index @s::@v::@x : !yasps.mat<3x1xf64>
// The union decodes the member; the energy gathers both points' slots.
// CHECK-LABEL: yasps.primitive_union @u
// CHECK: yasps.attr @x__dofs : !yasps.mat<12x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @w::@u::@x>} {
// CHECK-NEXT: yasps.union @x__udofs12 : !yasps.mat<12x1xf64>
// CHECK-LABEL: yasps.primitive @pp(2) dynamic
// CHECK: yasps.attr @e__dofs : !yasps.mat<24x1xf64> attributes {yasps.derivative = #yasps.derivative<dofs of @w::@pp::@e>} {
// CHECK: yasps.join @p2v(@w::@u::@x__dofs) : !yasps.mat<2x12xf64>
// CHECK: yasps.row %{{.*}}[0]
// CHECK: yasps.row %{{.*}}[1]
// CHECK: yasps.concat vertical {{.*}} -> !yasps.mat<24x1xf64>
yasps.scene @sc {
  yasps.mesh @r {
    yasps.primitive @b(1) {
      yasps.data_attr @A : !yasps.mat<3x3xf64>
      yasps.data_attr @t : !yasps.mat<3x1xf64>
    }
    yasps.primitive @v(1) {
      yasps.const_attr @rest : !yasps.mat<3x1xf64>
      yasps.connectivity @v2b -> @r::@b arity 1
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %a = yasps.join @v2b(@r::@b::@A) : !yasps.mat<1x9xf64>
        %t = yasps.join @v2b(@r::@b::@t) : !yasps.mat<1x3xf64>
        %r = yasps.read @r::@v::@rest : !yasps.mat<3x1xf64>
        %m = yasps.resize %a : !yasps.mat<1x9xf64> -> !yasps.mat<3x3xf64>
        %tc = yasps.resize %t : !yasps.mat<1x3xf64> -> !yasps.mat<3x1xf64>
        %p = yasps.matmul %m, %r : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x1xf64>
        %x = yasps.add %p, %tc : !yasps.mat<3x1xf64>
        yasps.yield %x : !yasps.mat<3x1xf64>
      }
    }
  }
  yasps.mesh @s {
    yasps.primitive @v(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
  }
  yasps.mesh @w {
    yasps.primitive_union @u [@r::@v, @s::@v] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
    yasps.primitive @pp(2) dynamic {
      yasps.connectivity @p2v -> @w::@u arity 2
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %p = yasps.join @p2v(@w::@u::@x) : !yasps.mat<2x3xf64>
        %d = yasps.squared_norm %p : !yasps.mat<2x3xf64>
        yasps.yield %d : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @w::@pp::@e dynamic_instances
  yasps.minimize [@s::@v::@x, @r::@b::@A, @r::@b::@t]
}
