// RUN: not yasps-opt %s -yasps-lower-to-loops="attributes=@m::@p::@y" 2>&1 | FileCheck %s
// JOINs evaluate their source once per gathered instance, so nesting
// multiplies: each level gathers 8 instances of the one below, and a few
// lines of IR ask for 8^7 evaluations of the innermost attribute. The
// error is met where the evaluation, depth first, passes the limit (a JOIN
// or a sum of the first levels).
// CHECK: error: 'yasps.{{join|sum}}' op makes kernel @yasps_eval_m__p__y exceed 524288 scalar operations per instance
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
