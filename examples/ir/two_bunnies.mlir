// The running example of the YASPS paper (section 4): a soft bunny and an
// affine bunny collide. The union of both bunnies' vertices feeds dynamic
// point-point collision pairs and the point-point barrier energy of section
// 4.6.3, minimised with respect to the soft positions and the affine body's
// matrix and translation. Sizes are those of ../shared/data/bunny-1.8k.msh.
//
//   yasps-opt examples/ir/two_bunnies.mlir

yasps.scene @scene0 {
  // Barrier parameters, shared by the whole scene (paper: DHAT, KAPPA).
  yasps.const_attr @dhat : !yasps.mat<1x1xf64>
  yasps.const_attr @kappa : !yasps.mat<1x1xf64>

  yasps.mesh @bunny_affine {
    yasps.primitive @vertices(1869) {
      yasps.const_attr @rest_position : !yasps.mat<3x1xf64>
      yasps.connectivity @bunny_vertex_to_affine_body -> @bunny_affine::@affine_body arity 1
      // JOIN the body's matrix and translation onto every vertex.
      yasps.attr @affine_matrix : !yasps.mat<1x9xf64> {
        %0 = yasps.join @bunny_vertex_to_affine_body(@bunny_affine::@affine_body::@affine_matrix) : !yasps.mat<1x9xf64>
        yasps.yield %0 : !yasps.mat<1x9xf64>
      }
      yasps.attr @translation : !yasps.mat<1x3xf64> {
        %0 = yasps.join @bunny_vertex_to_affine_body(@bunny_affine::@affine_body::@translation) : !yasps.mat<1x3xf64>
        yasps.yield %0 : !yasps.mat<1x3xf64>
      }
      // p = A p_rest + t
      yasps.attr @position : !yasps.mat<3x1xf64> {
        %a = yasps.read @bunny_affine::@vertices::@affine_matrix : !yasps.mat<1x9xf64>
        %t = yasps.read @bunny_affine::@vertices::@translation : !yasps.mat<1x3xf64>
        %r = yasps.read @bunny_affine::@vertices::@rest_position : !yasps.mat<3x1xf64>
        %A = yasps.resize %a : !yasps.mat<1x9xf64> -> !yasps.mat<3x3xf64>
        %tc = yasps.resize %t : !yasps.mat<1x3xf64> -> !yasps.mat<3x1xf64>
        %Ar = yasps.matmul %A, %r : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x1xf64>
        %p = yasps.add %Ar, %tc : !yasps.mat<3x1xf64>
        yasps.yield %p : !yasps.mat<3x1xf64>
      }
    }
    yasps.primitive @affine_body(1) {
      yasps.data_attr @affine_matrix : !yasps.mat<3x3xf64>
      yasps.data_attr @translation : !yasps.mat<3x1xf64>
    }
    yasps.primitive @tets(7356) {
      yasps.connectivity @tet2v -> @bunny_affine::@vertices arity 4
      yasps.attr @rest_positions : !yasps.mat<4x3xf64> {
        %0 = yasps.join @tet2v(@bunny_affine::@vertices::@rest_position) : !yasps.mat<4x3xf64>
        yasps.yield %0 : !yasps.mat<4x3xf64>
      }
      yasps.attr @positions : !yasps.mat<4x3xf64> {
        %0 = yasps.join @tet2v(@bunny_affine::@vertices::@position) : !yasps.mat<4x3xf64>
        yasps.yield %0 : !yasps.mat<4x3xf64>
      }
    }
  }

  yasps.mesh @bunny_soft {
    yasps.primitive @vertices(1869) {
      yasps.const_attr @rest_position : !yasps.mat<3x1xf64>
      yasps.data_attr @position : !yasps.mat<3x1xf64>
    }
    yasps.primitive @tets(7356) {
      yasps.connectivity @tet2v -> @bunny_soft::@vertices arity 4
      yasps.attr @positions : !yasps.mat<4x3xf64> {
        %0 = yasps.join @tet2v(@bunny_soft::@vertices::@position) : !yasps.mat<4x3xf64>
        yasps.yield %0 : !yasps.mat<4x3xf64>
      }
    }
  }

  yasps.mesh @bunnies {
    // Soft and affine vertices as one primitive type (UNION).
    yasps.primitive_union @vertices [@bunny_affine::@vertices, @bunny_soft::@vertices] {
      yasps.attr @rest_position : !yasps.mat<3x1xf64> {
        %0 = yasps.union @rest_position : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
      yasps.attr @position : !yasps.mat<3x1xf64> {
        %0 = yasps.union @position : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
    // Point-point collision pairs, found at run time.
    yasps.primitive @pp(0) dynamic {
      yasps.connectivity @pp2v -> @bunnies::@vertices arity 2
      yasps.attr @positions : !yasps.mat<2x3xf64> {
        %0 = yasps.join @pp2v(@bunnies::@vertices::@position) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
      // kappa (d - dhat)^2 log^2(d / dhat) with d the squared distance.
      yasps.attr @point_point : !yasps.mat<1x1xf64> {
        %pos = yasps.read @bunnies::@pp::@positions : !yasps.mat<2x3xf64>
        %dhat = yasps.read @dhat : !yasps.mat<1x1xf64>
        %kappa = yasps.read @kappa : !yasps.mat<1x1xf64>
        %p0 = yasps.row %pos[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %p1 = yasps.row %pos[1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %e = yasps.sub %p1, %p0 : !yasps.mat<1x3xf64>
        %d = yasps.dot %e, %e : !yasps.mat<1x3xf64>
        %i5 = yasps.div %d, %dhat : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %len = yasps.sub %d, %dhat : !yasps.mat<1x1xf64>
        %lg = yasps.log %i5 : !yasps.mat<1x1xf64>
        %k1 = yasps.scale %kappa, %len : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %k2 = yasps.scale %k1, %len : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %k3 = yasps.scale %k2, %lg : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %k4 = yasps.scale %k3, %lg : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %k4 : !yasps.mat<1x1xf64>
      }
    }
  }

  yasps.energy @bunnies::@pp::@point_point dynamic_instances
  yasps.minimize [@bunny_soft::@vertices::@position, @bunny_affine::@affine_body::@affine_matrix, @bunny_affine::@affine_body::@translation]
}
