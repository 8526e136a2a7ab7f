// RUN: yasps-opt %s -yasps-differentiate=hessian-factors=auto | FileCheck %s --check-prefix=AUTO
// RUN: yasps-opt %s -yasps-differentiate=hessian-factors=always | FileCheck %s --check-prefix=ALWAYS
// RUN: not yasps-opt %s -yasps-differentiate=hessian-factors=sometimes 2>&1 | FileCheck %s --check-prefix=BAD

// hessian-factors=auto keeps reduced-space factors apart only where they
// hold at most half the values of the n x n Hessian (2 m (n + m) <= n^2).
// Here each end of the edge has 4 parameters (p, s) behind 3 gathered
// entries (x = p + s c): m = 6, n = 8, 168 > 64, so the 8x8 product is
// formed in the kernel (differentiate-separate.mlir has a case that keeps
// the factors). With always, the factors and the unprojected inner
// Hessian are attributes of their own.
// AUTO: yasps.attr @k__hess_proj : !yasps.mat<8x8xf64> attributes {{{.*}}yasps.projection = #yasps.projection<reduced>}
// AUTO-NOT: @k__hess_inner
// ALWAYS: yasps.attr @k__hess_inner : !yasps.mat<6x6xf64> attributes {yasps.derivative = #yasps.derivative<hess_inner of @m::@e::@k>
// ALWAYS-NEXT: yasps.read @m::@e::@k__ijac__ijac : !yasps.mat<6x6xf64>
// ALWAYS: yasps.attr @k__hess_inner_proj : !yasps.mat<6x6xf64> attributes {{{.*}}yasps.projection = #yasps.projection<separate>}
// ALWAYS-NOT: @k__hess_proj
// The option is an enum (HessianFactors.h): a value it does not take is
// refused when the pipeline is parsed.
// BAD: Cannot find option named 'sometimes'
module {
yasps.scene @sc {
    yasps.mesh @m {
      yasps.primitive @v(2) {
        yasps.data_attr @p : !yasps.mat<3x1xf64>
        yasps.data_attr @s : !yasps.mat<1x1xf64>
        yasps.const_attr @c : !yasps.mat<3x1xf64>
        yasps.attr @x : !yasps.mat<3x1xf64> {
          %0 = yasps.read @m::@v::@p : !yasps.mat<3x1xf64>
          %1 = yasps.read @m::@v::@c : !yasps.mat<3x1xf64>
          %2 = yasps.read @m::@v::@s : !yasps.mat<1x1xf64>
          %3 = yasps.scale %1, %2 : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>
          %4 = yasps.add %0, %3 : !yasps.mat<3x1xf64>
          yasps.yield %4 : !yasps.mat<3x1xf64>
        }
      }
      yasps.primitive @e(1) {
        yasps.connectivity @e2v -> @m::@v arity 2
        yasps.attr @x : !yasps.mat<2x3xf64> {
          %0 = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
          yasps.yield %0 : !yasps.mat<2x3xf64>
        }
        yasps.attr @k : !yasps.mat<1x1xf64> {
          %0 = yasps.constant dense<2.000000e+00> : tensor<1x1xf64>
          %1 = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf64>
          %2 = yasps.row %1[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
          %3 = yasps.row %1[1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
          %4 = yasps.sub %2, %3 : !yasps.mat<1x3xf64>
          %5 = yasps.squared_norm %4 : !yasps.mat<1x3xf64>
          %6 = yasps.pow %5, %0 : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
          yasps.yield %6 : !yasps.mat<1x1xf64>
        }
      }
    }
    yasps.energy @m::@e::@k
    yasps.minimize [@m::@v::@p, @m::@v::@s]
  }
}

