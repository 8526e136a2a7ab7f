// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@b,@m::@p::@a" | FileCheck %s
// RUN: yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@nope" -verify-diagnostics -split-input-file

// Kernels for the attributes named by the option, in its order; the scene
// stays until yasps-strip-scenes.

// CHECK: yasps.scene @s
// CHECK: func.func @yasps_eval_m__p__b
// CHECK: func.func @yasps_eval_m__p__a
// expected-error @+1 {{yasps-lower-to-loops: @m::@p::@nope does not name an attribute of scene @s}}
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<2x2xf64>
      yasps.attr @b : !yasps.mat<2x2xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<2x2xf64>
        %t = yasps.transpose %a : !yasps.mat<2x2xf64> -> !yasps.mat<2x2xf64>
        yasps.yield %t : !yasps.mat<2x2xf64>
      }
    }
  }
}
