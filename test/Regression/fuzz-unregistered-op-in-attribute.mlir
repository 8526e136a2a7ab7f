// RUN: yasps-opt %s -verify-diagnostics -allow-unregistered-dialect
// Found by scripts/fuzz.sh: an unregistered op (generic syntax, named
// "yasps." or another dialect's) in an attribute region made the verifier
// bind a reference to the null dialect of an unregistered op (UBSan).
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.attr @a : !yasps.mat<3x1xf64> {
        %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
        // expected-error @below {{is not a yasps expression; computed attribute @m::@p::@a may only contain yasps ops}}
        %1 = "yasps."(%0, %0) : (!yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>) -> !yasps.mat<3x1xf64>
        yasps.yield %1 : !yasps.mat<3x1xf64>
      }
    }
  }
}
