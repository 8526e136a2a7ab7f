// RUN: yasps-opt %s | FileCheck %s
// RUN: yasps-opt %s | yasps-opt | FileCheck %s
// RUN: yasps-opt %s --mlir-print-op-generic | yasps-opt | FileCheck %s

// Every structure op and every expression op, printed and re-parsed.

// CHECK-LABEL: yasps.scene @structure
yasps.scene @structure {
  // CHECK: yasps.const_attr @dt : !yasps.mat<1x1xf64>
  yasps.const_attr @dt : !yasps.mat<1x1xf64>
  // CHECK: yasps.mesh @m {
  yasps.mesh @m {
    // CHECK: yasps.data_attr @stiffness : !yasps.mat<1x1xf32>
    yasps.data_attr @stiffness : !yasps.mat<1x1xf32>
    // CHECK: yasps.primitive @v(4) {
    yasps.primitive @v(4) {
      // CHECK: yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      // CHECK: yasps.attr @dofs : !yasps.mat<3x1xf64> {
      // CHECK-NEXT: yasps.dof_index @m::@v::@x : !yasps.mat<3x1xf64>
      yasps.attr @dofs : !yasps.mat<3x1xf64> {
        %0 = yasps.dof_index @m::@v::@x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
      // CHECK: yasps.const_attr @mass : !yasps.mat<1x1xf64>
      yasps.const_attr @mass : !yasps.mat<1x1xf64>
    }
    // CHECK: yasps.primitive @w(0) dynamic {
    yasps.primitive @w(0) dynamic {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @height : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@w::@x : !yasps.mat<3x1xf64>
        %1 = yasps.element %0[2, 0] : !yasps.mat<3x1xf64>
        yasps.yield %1 : !yasps.mat<1x1xf64>
      }
    }
    // CHECK: yasps.primitive_union @all [@m::@v, @m::@w] {
    yasps.primitive_union @all [@m::@v, @m::@w] {
      // CHECK: yasps.attr @x : !yasps.mat<3x1xf64> {
      // CHECK-NEXT: %[[U:.*]] = yasps.union @x : !yasps.mat<3x1xf64>
      // CHECK-NEXT: yasps.yield %[[U]] : !yasps.mat<3x1xf64>
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
    // CHECK: yasps.primitive_union @nested [@m::@all] {
    yasps.primitive_union @nested [@m::@all] {
    }
    // CHECK: yasps.primitive @e(2) {
    yasps.primitive @e(2) {
      // CHECK: yasps.connectivity @e2v -> @m::@all arity 2
      yasps.connectivity @e2v -> @m::@all arity 2
      // CHECK: yasps.join @e2v(@m::@all::@x) : !yasps.mat<2x3xf64>
      yasps.attr @ends : !yasps.mat<2x3xf64> {
        %0 = yasps.join @e2v(@m::@all::@x) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
      // CHECK: yasps.attr @length : !yasps.mat<1x1xf64> {
      yasps.attr @length : !yasps.mat<1x1xf64> {
        // CHECK: yasps.read @m::@e::@ends : !yasps.mat<2x3xf64>
        %0 = yasps.read @m::@e::@ends : !yasps.mat<2x3xf64>
        // CHECK: yasps.read @dt : !yasps.mat<1x1xf64>
        %dt = yasps.read @dt : !yasps.mat<1x1xf64>
        %1 = yasps.row %0[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %2 = yasps.row %0[1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
        %3 = yasps.sub %2, %1 : !yasps.mat<1x3xf64>
        %4 = yasps.norm %3 : !yasps.mat<1x3xf64>
        %5 = yasps.scale %4, %dt : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %5 : !yasps.mat<1x1xf64>
      }
    }
  }
  // CHECK: yasps.energy @m::@w::@height dynamic_instances
  yasps.energy @m::@w::@height dynamic_instances
  // CHECK: yasps.energy @m::@e::@length{{$}}
  yasps.energy @m::@e::@length
  // CHECK: yasps.minimize [@m::@v::@x, @m::@stiffness]
  yasps.minimize [@m::@v::@x, @m::@stiffness]
}

// CHECK-LABEL: yasps.scene @expressions
yasps.scene @expressions {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @a : !yasps.mat<3x3xf64>
      yasps.data_attr @v : !yasps.mat<3x1xf64>
      yasps.data_attr @s : !yasps.mat<1x1xf64>
      yasps.attr @all_ops : !yasps.mat<1x1xf64> {
        %a = yasps.read @m::@p::@a : !yasps.mat<3x3xf64>
        %v = yasps.read @m::@p::@v : !yasps.mat<3x1xf64>
        %s = yasps.read @m::@p::@s : !yasps.mat<1x1xf64>
        // CHECK: yasps.constant dense<5.000000e-01> : tensor<1x1xf64>
        %c = yasps.constant dense<0.5> : tensor<1x1xf64>
        // CHECK: yasps.constant dense<{{\[\[}}1.000000e+00, 2.000000e+00], [3.000000e+00, 4.000000e+00]]> : tensor<2x2xf64>
        %lit = yasps.constant dense<[[1.0, 2.0], [3.0, 4.0]]> : tensor<2x2xf64>
        // CHECK: yasps.constant dense<0.000000e+00> : tensor<3x3xf64>
        %z = yasps.constant dense<0.0> : tensor<3x3xf64>
        // CHECK: yasps.identity : !yasps.mat<3x3xf64>
        %i = yasps.identity : !yasps.mat<3x3xf64>
        // CHECK: yasps.add %{{.*}}, %{{.*}} : !yasps.mat<3x3xf64>
        %add = yasps.add %a, %i : !yasps.mat<3x3xf64>
        // CHECK: yasps.sub %{{.*}}, %{{.*}} : !yasps.mat<3x3xf64>
        %sub = yasps.sub %add, %z : !yasps.mat<3x3xf64>
        // CHECK: yasps.neg %{{.*}} : !yasps.mat<3x3xf64>
        %neg = yasps.neg %sub : !yasps.mat<3x3xf64>
        // CHECK: yasps.matmul %{{.*}}, %{{.*}} : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x1xf64>
        %mv = yasps.matmul %neg, %v : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x1xf64>
        // CHECK: yasps.scale %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>
        %sc = yasps.scale %mv, %s : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>
        // CHECK: yasps.div %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>
        %dv = yasps.div %sc, %c : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>
        // CHECK: yasps.elementwise_mul %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>
        %em = yasps.elementwise_mul %dv, %v : !yasps.mat<3x1xf64>
        // CHECK: yasps.transpose %{{.*}} : !yasps.mat<3x1xf64> -> !yasps.mat<1x3xf64>
        %t = yasps.transpose %em : !yasps.mat<3x1xf64> -> !yasps.mat<1x3xf64>
        // CHECK: yasps.dot %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>
        %dot = yasps.dot %em, %v : !yasps.mat<3x1xf64>
        // CHECK: yasps.cross %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>
        %cr = yasps.cross %em, %v : !yasps.mat<3x1xf64>
        // CHECK: yasps.row %{{.*}}[2] : !yasps.mat<3x3xf64> -> !yasps.mat<1x3xf64>
        %row = yasps.row %a[2] : !yasps.mat<3x3xf64> -> !yasps.mat<1x3xf64>
        // CHECK: yasps.col %{{.*}}[1] : !yasps.mat<3x3xf64> -> !yasps.mat<3x1xf64>
        %col = yasps.col %a[1] : !yasps.mat<3x3xf64> -> !yasps.mat<3x1xf64>
        // CHECK: yasps.element %{{.*}}[1, 2] : !yasps.mat<3x3xf64>
        %el = yasps.element %a[1, 2] : !yasps.mat<3x3xf64>
        // CHECK: yasps.slice %{{.*}}[1, 0] : !yasps.mat<3x3xf64> -> !yasps.mat<2x3xf64>
        %sl = yasps.slice %a[1, 0] : !yasps.mat<3x3xf64> -> !yasps.mat<2x3xf64>
        // CHECK: yasps.resize %{{.*}} : !yasps.mat<2x3xf64> -> !yasps.mat<3x2xf64>
        %rs = yasps.resize %sl : !yasps.mat<2x3xf64> -> !yasps.mat<3x2xf64>
        // CHECK: yasps.concat vertical %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<6x1xf64>
        %vc = yasps.concat vertical %col, %cr : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<6x1xf64>
        // CHECK: yasps.concat horizontal %{{.*}}, %{{.*}} : !yasps.mat<3x2xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x3xf64>
        %hc = yasps.concat horizontal %rs, %col : !yasps.mat<3x2xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x3xf64>
        // CHECK: yasps.det %{{.*}} : !yasps.mat<3x3xf64>
        %det = yasps.det %hc : !yasps.mat<3x3xf64>
        // CHECK: yasps.inverse %{{.*}} : !yasps.mat<3x3xf64>
        %inv = yasps.inverse %hc : !yasps.mat<3x3xf64>
        // CHECK: yasps.cofactor %{{.*}} : !yasps.mat<3x3xf64>
        %cof = yasps.cofactor %hc : !yasps.mat<3x3xf64>
        // CHECK: yasps.trace %{{.*}} : !yasps.mat<3x3xf64>
        %tr = yasps.trace %inv : !yasps.mat<3x3xf64>
        // CHECK: yasps.singular_value_sum %{{.*}} : !yasps.mat<3x3xf64>
        %svs = yasps.singular_value_sum %hc : !yasps.mat<3x3xf64>
        // CHECK: yasps.norm %{{.*}} : !yasps.mat<6x1xf64>
        %nrm = yasps.norm %vc : !yasps.mat<6x1xf64>
        // CHECK: yasps.squared_norm %{{.*}} : !yasps.mat<1x3xf64>
        %sq = yasps.squared_norm %t : !yasps.mat<1x3xf64>
        // CHECK: yasps.sum %{{.*}} : !yasps.mat<1x3xf64>
        %sum = yasps.sum %row : !yasps.mat<1x3xf64>
        // CHECK: yasps.sqrt %{{.*}} : !yasps.mat<1x1xf64>
        %sqrt = yasps.sqrt %sq : !yasps.mat<1x1xf64>
        // CHECK: yasps.log %{{.*}} : !yasps.mat<1x1xf64>
        %log = yasps.log %sqrt : !yasps.mat<1x1xf64>
        // CHECK: yasps.exp %{{.*}} : !yasps.mat<1x1xf64>
        %exp = yasps.exp %log : !yasps.mat<1x1xf64>
        // CHECK: yasps.pow %{{.*}}, %{{.*}} : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %pow = yasps.pow %exp, %c : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        // CHECK: yasps.pow %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>
        %pow3 = yasps.pow %v, %v : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>
        // CHECK: yasps.sin %{{.*}} : !yasps.mat<1x1xf64>
        %sin = yasps.sin %pow : !yasps.mat<1x1xf64>
        // CHECK: yasps.cos %{{.*}} : !yasps.mat<1x1xf64>
        %cos = yasps.cos %sin : !yasps.mat<1x1xf64>
        // CHECK: yasps.atan2 %{{.*}}, %{{.*}} : !yasps.mat<1x1xf64>
        %at = yasps.atan2 %sin, %cos : !yasps.mat<1x1xf64>
        // CHECK: yasps.abs %{{.*}} : !yasps.mat<1x1xf64>
        %abs = yasps.abs %at : !yasps.mat<1x1xf64>
        // CHECK: yasps.min %{{.*}}, %{{.*}} : !yasps.mat<1x1xf64>
        %min = yasps.min %abs, %det : !yasps.mat<1x1xf64>
        // CHECK: yasps.max %{{.*}}, %{{.*}} : !yasps.mat<1x1xf64>
        %max = yasps.max %min, %tr : !yasps.mat<1x1xf64>
        // CHECK: yasps.cmp lt, %{{.*}}, %{{.*}} : !yasps.mat<1x1xf64>
        %lt = yasps.cmp lt, %max, %nrm : !yasps.mat<1x1xf64>
        // CHECK: yasps.cmp ne, %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>
        %ne = yasps.cmp ne, %v, %pow3 : !yasps.mat<3x1xf64>
        // CHECK: yasps.select %{{.*}}, %{{.*}}, %{{.*}} : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        %sel = yasps.select %lt, %max, %sum : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        // CHECK: yasps.select %{{.*}}, %{{.*}}, %{{.*}} : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>
        %sel3 = yasps.select %ne, %v, %pow3 : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>
        // CHECK: yasps.stop_gradient %{{.*}} : !yasps.mat<1x1xf64>
        %sg = yasps.stop_gradient %sel : !yasps.mat<1x1xf64>
        // CHECK: yasps.project clamp %{{.*}} : !yasps.mat<3x3xf64>
        %pc = yasps.project clamp %a : !yasps.mat<3x3xf64>
        // CHECK: yasps.project abs %{{.*}} : !yasps.mat<3x3xf64>
        %pa = yasps.project abs %pc : !yasps.mat<3x3xf64>
        // CHECK: yasps.project none %{{.*}} : !yasps.mat<3x3xf64>
        %pn = yasps.project none %pa : !yasps.mat<3x3xf64>
        %q = yasps.trace %pn : !yasps.mat<3x3xf64>
        %d3 = yasps.dot %sel3, %sel3 : !yasps.mat<3x1xf64>
        %r1 = yasps.add %sg, %q : !yasps.mat<1x1xf64>
        %r2 = yasps.add %r1, %d3 : !yasps.mat<1x1xf64>
        %r3 = yasps.add %r2, %el : !yasps.mat<1x1xf64>
        %r4 = yasps.add %r3, %dot : !yasps.mat<1x1xf64>
        // CHECK: yasps.yield %{{.*}} : !yasps.mat<1x1xf64>
        yasps.yield %r4 : !yasps.mat<1x1xf64>
      }
      // f32 expressions
      yasps.attr @single : !yasps.mat<2x2xf32> {
        // CHECK: yasps.constant dense<{{\[\[}}1.000000e+00, 0.000000e+00], [0.000000e+00, 2.000000e+00]]> : tensor<2x2xf32>
        %0 = yasps.constant dense<[[1.0, 0.0], [0.0, 2.0]]> : tensor<2x2xf32>
        // CHECK: yasps.inverse %{{.*}} : !yasps.mat<2x2xf32>
        %1 = yasps.inverse %0 : !yasps.mat<2x2xf32>
        yasps.yield %1 : !yasps.mat<2x2xf32>
      }
    }
  }
}

// CHECK-LABEL: yasps.scene @projections
yasps.scene @projections {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @e : !yasps.mat<1x1xf64>
      yasps.data_attr @f : !yasps.mat<1x1xf64>
    }
  }
  // CHECK: yasps.energy @m::@p::@e projection abs
  yasps.energy @m::@p::@e projection abs
  // CHECK: yasps.energy @m::@p::@f{{$}}
  yasps.energy @m::@p::@f projection clamp
}
