// RUN: yasps-opt %s -canonicalize -split-input-file | FileCheck %s

// Each function-like attribute checks one fold.

yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(3) {
      yasps.data_attr @x : !yasps.mat<3x2xf64>
      yasps.data_attr @a : !yasps.mat<3x3xf64>
      yasps.data_attr @s : !yasps.mat<1x1xf64>

      // CHECK-LABEL: yasps.attr @transpose_of_transpose
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @transpose_of_transpose : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %t = yasps.transpose %x : !yasps.mat<3x2xf64> -> !yasps.mat<2x3xf64>
        %tt = yasps.transpose %t : !yasps.mat<2x3xf64> -> !yasps.mat<3x2xf64>
        yasps.yield %tt : !yasps.mat<3x2xf64>
      }

      // The cofactor matrix of a constant is a constant (signed 2x2 minors).
      // CHECK-LABEL: yasps.attr @cofactor_of_constant
      // CHECK-NEXT: %[[C:.*]] = yasps.constant dense<{{\[\[}}-1.000000e+00, -2.000000e+00, 1.000000e+00], [-1.000000e+00, 2.000000e+00, -1.000000e+00], [1.000000e+00, 0.000000e+00, -1.000000e+00]]>
      // CHECK-NEXT: yasps.yield %[[C]]
      yasps.attr @cofactor_of_constant : !yasps.mat<3x3xf64> {
        %a = yasps.constant dense<[[1.0, 1.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 2.0]]> : tensor<3x3xf64>
        %c = yasps.cofactor %a : !yasps.mat<3x3xf64>
        yasps.yield %c : !yasps.mat<3x3xf64>
      }

      // CHECK-LABEL: yasps.attr @scale_by_one
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @scale_by_one : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %one = yasps.constant dense<1.0> : tensor<1x1xf64>
        %r = yasps.scale %x, %one : !yasps.mat<3x2xf64>, !yasps.mat<1x1xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // CHECK-LABEL: yasps.attr @divide_by_one
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @divide_by_one : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %one = yasps.constant dense<1.0> : tensor<1x1xf64>
        %r = yasps.div %x, %one : !yasps.mat<3x2xf64>, !yasps.mat<1x1xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // CHECK-LABEL: yasps.attr @elementwise_times_ones
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @elementwise_times_ones : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %ones = yasps.constant dense<1.0> : tensor<3x2xf64>
        %r = yasps.elementwise_mul %ones, %x : !yasps.mat<3x2xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // CHECK-LABEL: yasps.attr @matmul_by_identity
      // CHECK-NEXT: %[[A:.*]] = yasps.read @m::@p::@a
      // CHECK-NEXT: yasps.yield %[[A]]
      yasps.attr @matmul_by_identity : !yasps.mat<3x3xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<3x3xf64>
        %i = yasps.identity : !yasps.mat<3x3xf64>
        %l = yasps.matmul %i, %a : !yasps.mat<3x3xf64>, !yasps.mat<3x3xf64> -> !yasps.mat<3x3xf64>
        %r = yasps.matmul %l, %i : !yasps.mat<3x3xf64>, !yasps.mat<3x3xf64> -> !yasps.mat<3x3xf64>
        yasps.yield %r : !yasps.mat<3x3xf64>
      }

      // Adding -0.0 is the identity for every x; adding +0.0 is not (-0.0 +
      // 0.0 is +0.0), so it stays, as in upstream's arith folds: values
      // keep NumPy's bits.
      // CHECK-LABEL: yasps.attr @add_zero
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @add_zero : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %z = yasps.constant dense<-0.0> : tensor<3x2xf64>
        %l = yasps.add %z, %x : !yasps.mat<3x2xf64>
        %r = yasps.add %l, %z : !yasps.mat<3x2xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // CHECK-LABEL: yasps.attr @add_positive_zero
      // CHECK: %[[S:.*]] = yasps.add
      // CHECK-NEXT: yasps.yield %[[S]]
      yasps.attr @add_positive_zero : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %z = yasps.constant dense<0.0> : tensor<3x2xf64>
        %r = yasps.add %z, %x : !yasps.mat<3x2xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // Subtracting +0.0 is the identity; subtracting -0.0 is adding +0.0.
      // CHECK-LABEL: yasps.attr @sub_zero
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @sub_zero : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %z = yasps.constant dense<0.0> : tensor<3x2xf64>
        %r = yasps.sub %x, %z : !yasps.mat<3x2xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // CHECK-LABEL: yasps.attr @sub_negative_zero
      // CHECK: yasps.sub
      yasps.attr @sub_negative_zero : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %z = yasps.constant dense<-0.0> : tensor<3x2xf64>
        %r = yasps.sub %x, %z : !yasps.mat<3x2xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // Zero minus x is not x.
      // CHECK-LABEL: yasps.attr @zero_minus_x
      // CHECK: yasps.sub
      yasps.attr @zero_minus_x : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %z = yasps.constant dense<0.0> : tensor<3x2xf64>
        %r = yasps.sub %z, %x : !yasps.mat<3x2xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }

      // CHECK-LABEL: yasps.attr @double_negation
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: yasps.yield %[[X]]
      yasps.attr @double_negation : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %n = yasps.neg %x : !yasps.mat<3x2xf64>
        %nn = yasps.neg %n : !yasps.mat<3x2xf64>
        yasps.yield %nn : !yasps.mat<3x2xf64>
      }

      // 2 * (3 + 4) / 7 - 0.5 = 1.5, negated.
      // CHECK-LABEL: yasps.attr @scalar_arithmetic
      // CHECK-NEXT: %[[C:.*]] = yasps.constant dense<-1.500000e+00> : tensor<1x1xf64>
      // CHECK-NEXT: yasps.yield %[[C]]
      yasps.attr @scalar_arithmetic : !yasps.mat<1x1xf64> {
        %two = yasps.constant dense<2.0> : tensor<1x1xf64>
        %three = yasps.constant dense<3.0> : tensor<1x1xf64>
        %four = yasps.constant dense<4.0> : tensor<1x1xf64>
        %seven = yasps.constant dense<7.0> : tensor<1x1xf64>
        %half = yasps.constant dense<0.5> : tensor<1x1xf64>
        %sum = yasps.add %three, %four : !yasps.mat<1x1xf64>
        %prod = yasps.scale %two, %sum : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %quot = yasps.div %prod, %seven : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %diff = yasps.sub %quot, %half : !yasps.mat<1x1xf64>
        %neg = yasps.neg %diff : !yasps.mat<1x1xf64>
        yasps.yield %neg : !yasps.mat<1x1xf64>
      }

      // CHECK-LABEL: yasps.attr @matrix_constant_arithmetic
      // CHECK-NEXT: %[[C:.*]] = yasps.constant dense<{{\[\[}}1.400000e+01], [3.100000e+01]]> : tensor<2x1xf64>
      // CHECK-NEXT: yasps.yield %[[C]]
      yasps.attr @matrix_constant_arithmetic : !yasps.mat<2x1xf64> {
        %m = yasps.constant dense<[[1.0, 2.0], [3.0, 4.0]]> : tensor<2x2xf64>
        %v = yasps.constant dense<[[1.0], [2.0]]> : tensor<2x1xf64>
        %mv = yasps.matmul %m, %v : !yasps.mat<2x2xf64>, !yasps.mat<2x1xf64> -> !yasps.mat<2x1xf64>
        %w = yasps.constant dense<[[3.0], [3.0]]> : tensor<2x1xf64>
        %ew = yasps.elementwise_mul %mv, %w : !yasps.mat<2x1xf64>
        %t = yasps.transpose %ew : !yasps.mat<2x1xf64> -> !yasps.mat<1x2xf64>
        %tt = yasps.transpose %t : !yasps.mat<1x2xf64> -> !yasps.mat<2x1xf64>
        %r = yasps.sub %tt, %v : !yasps.mat<2x1xf64>
        yasps.yield %r : !yasps.mat<2x1xf64>
      }

      // CHECK-LABEL: yasps.attr @constant_transpose
      // CHECK-NEXT: %[[C:.*]] = yasps.constant dense<{{\[\[}}1.000000e+00, 3.000000e+00], [2.000000e+00, 4.000000e+00]]> : tensor<2x2xf64>
      // CHECK-NEXT: yasps.yield %[[C]]
      yasps.attr @constant_transpose : !yasps.mat<2x2xf64> {
        %m = yasps.constant dense<[[1.0, 2.0], [3.0, 4.0]]> : tensor<2x2xf64>
        %t = yasps.transpose %m : !yasps.mat<2x2xf64> -> !yasps.mat<2x2xf64>
        yasps.yield %t : !yasps.mat<2x2xf64>
      }

      // CHECK-LABEL: yasps.attr @f32_arithmetic
      // CHECK-NEXT: %[[C:.*]] = yasps.constant dense<1.250000e+00> : tensor<1x1xf32>
      // CHECK-NEXT: yasps.yield %[[C]]
      yasps.attr @f32_arithmetic : !yasps.mat<1x1xf32> {
        %a = yasps.constant dense<0.5> : tensor<1x1xf32>
        %b = yasps.constant dense<0.75> : tensor<1x1xf32>
        %r = yasps.add %a, %b : !yasps.mat<1x1xf32>
        yasps.yield %r : !yasps.mat<1x1xf32>
      }

      // CHECK-LABEL: yasps.attr @stop_gradient_twice
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@s
      // CHECK-NEXT: %[[G:.*]] = yasps.stop_gradient %[[X]]
      // CHECK-NEXT: yasps.yield %[[G]]
      yasps.attr @stop_gradient_twice : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@s : !yasps.mat<1x1xf64>
        %g = yasps.stop_gradient %x : !yasps.mat<1x1xf64>
        %gg = yasps.stop_gradient %g : !yasps.mat<1x1xf64>
        yasps.yield %gg : !yasps.mat<1x1xf64>
      }

      // CHECK-LABEL: yasps.attr @resize_twice
      // CHECK-NEXT: %[[X:.*]] = yasps.read @m::@p::@x
      // CHECK-NEXT: %[[R:.*]] = yasps.resize %[[X]] : !yasps.mat<3x2xf64> -> !yasps.mat<1x6xf64>
      // CHECK-NEXT: yasps.yield %[[R]]
      yasps.attr @resize_twice : !yasps.mat<1x6xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %r1 = yasps.resize %x : !yasps.mat<3x2xf64> -> !yasps.mat<2x3xf64>
        %r2 = yasps.resize %r1 : !yasps.mat<2x3xf64> -> !yasps.mat<1x6xf64>
        yasps.yield %r2 : !yasps.mat<1x6xf64>
      }

      // Scaling by a non-unit scalar stays.
      // CHECK-LABEL: yasps.attr @scale_by_two
      // CHECK: yasps.scale
      yasps.attr @scale_by_two : !yasps.mat<3x2xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x2xf64>
        %two = yasps.constant dense<2.0> : tensor<1x1xf64>
        %r = yasps.scale %x, %two : !yasps.mat<3x2xf64>, !yasps.mat<1x1xf64>
        yasps.yield %r : !yasps.mat<3x2xf64>
      }
    }
  }
}
