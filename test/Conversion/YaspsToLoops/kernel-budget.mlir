// RUN: yasps-opt %s -verify-diagnostics -yasps-lower-to-loops="attributes=@m::@p::@y"

// A kernel is straight-line code per instance: a 128x128 product is 2M
// multiply-adds, past the 2^19 a kernel may emit. It is refused before any
// of it is emitted (it took 11 s of lowering and 214 MB of IR before).
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<128x128xf64>
      yasps.attr @y : !yasps.mat<128x128xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<128x128xf64>
        // expected-error @below {{makes kernel @yasps_eval_m__p__y exceed 524288 scalar operations per instance}}
        %p = yasps.matmul %a, %a : !yasps.mat<128x128xf64>, !yasps.mat<128x128xf64> -> !yasps.mat<128x128xf64>
        yasps.yield %p : !yasps.mat<128x128xf64>
      }
    }
  }
}

