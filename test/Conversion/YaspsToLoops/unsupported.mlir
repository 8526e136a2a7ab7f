// RUN: yasps-opt %s -yasps-lower-to-loops -verify-diagnostics

// Determinants and inverses are expanded in closed form up to 4x4 only.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<5x5xf64>
      yasps.attr @d : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<5x5xf64>
        // expected-error @+1 {{determinant of '!yasps.mat<5x5xf64>' is not supported in kernels (at most 4x4)}}
        %d = yasps.det %a : !yasps.mat<5x5xf64>
        yasps.yield %d : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@d
}
