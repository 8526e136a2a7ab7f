// RUN: yasps-opt %s -split-input-file -verify-diagnostics -yasps-lower-to-loops="attributes=@m::@p::@y"

// A kernel is straight-line code per instance: a 128x128 product is 2M
// multiply-adds, past the 2^20 a kernel may emit. It is refused before any
// of it is emitted (it took 11 s of lowering and 214 MB of IR before).
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<128x128xf64>
      yasps.attr @y : !yasps.mat<128x128xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<128x128xf64>
        // expected-error @below {{makes kernel @yasps_eval_m__p__y exceed 1048576 scalar operations per instance}}
        %p = yasps.matmul %a, %a : !yasps.mat<128x128xf64>, !yasps.mat<128x128xf64> -> !yasps.mat<128x128xf64>
        yasps.yield %p : !yasps.mat<128x128xf64>
      }
    }
  }
}

// -----

// JOINs evaluate their source once per gathered instance, so nesting
// multiplies: each level gathers 8 instances of the one below, and a few
// lines of IR ask for 8^7 evaluations of the innermost attribute. The
// error is met where the evaluation, depth first, passes the limit.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(8) {
      yasps.data_attr @a : !yasps.mat<1x1xf64>
      yasps.connectivity @c -> @m::@p arity 8
      yasps.attr @y0 : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<1x1xf64>
        yasps.yield %a : !yasps.mat<1x1xf64>
      }
      yasps.attr @y1 : !yasps.mat<1x1xf64> {
        // expected-error @below {{exceed 1048576 scalar operations}}
        %j = yasps.join @c(@m::@p::@y0) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y2 : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@p::@y1) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y3 : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@p::@y2) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y4 : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@p::@y3) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y5 : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@p::@y4) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y6 : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@p::@y5) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y7 : !yasps.mat<1x1xf64> {
        %j = yasps.join @c(@m::@p::@y6) : !yasps.mat<8x1xf64>
        %s = yasps.sum %j : !yasps.mat<8x1xf64>
        yasps.yield %s : !yasps.mat<1x1xf64>
      }
      yasps.attr @y : !yasps.mat<1x1xf64> {
        %r = yasps.read @m::@p::@y7 : !yasps.mat<1x1xf64>
        yasps.yield %r : !yasps.mat<1x1xf64>
      }
    }
  }
}
