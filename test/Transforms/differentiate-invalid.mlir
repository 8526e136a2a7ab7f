// RUN: yasps-opt %s -split-input-file -yasps-differentiate -verify-diagnostics

// Energies must be inlined first.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @n : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<3x1xf64>
        %n = yasps.squared_norm %x : !yasps.mat<3x1xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
      yasps.attr @e : !yasps.mat<1x1xf64> {
        // expected-error @+1 {{reads computed attribute @m::@p::@n: inline computed attributes (yasps-inline-reads) before yasps-differentiate}}
        %n = yasps.read @m::@p::@n : !yasps.mat<1x1xf64>
        yasps.yield %n : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
  yasps.minimize [@m::@p::@x]
}

// -----

// PSD projection is applied to derivatives, not differentiated.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @h : !yasps.mat<2x2xf64>
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %h = yasps.read @m::@p::@h : !yasps.mat<2x2xf64>
        // expected-error @+1 {{cannot be differentiated: PSD projection applies to derivatives, not before them}}
        %p = yasps.project clamp %h : !yasps.mat<2x2xf64>
        %t = yasps.trace %p : !yasps.mat<2x2xf64>
        yasps.yield %t : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
  yasps.minimize [@m::@p::@h]
}

// -----

// A derivative's name that an attribute of the scene already has.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<1x1xf64>
      yasps.const_attr @e__grad : !yasps.mat<1x1xf64>
      // expected-error @+1 {{cannot add @e__grad: the name is taken}}
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<1x1xf64>
        %e = yasps.squared_norm %x : !yasps.mat<1x1xf64>
        yasps.yield %e : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
  yasps.minimize [@m::@p::@x]
}

// -----

// 200 local parameters: the 200x200 Hessian is past the matrix limit, and
// the pass says so instead of building it.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<1x200xf64>
      // expected-error @+1 {{needs @e__jac__jac of 200x200 entries per instance, more than the 16384 a yasps matrix may have}}
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %x = yasps.read @m::@p::@x : !yasps.mat<1x200xf64>
        %n = yasps.squared_norm %x : !yasps.mat<1x200xf64>
        %q = yasps.scale %n, %n : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf64>
        yasps.yield %q : !yasps.mat<1x1xf64>
      }
    }
  }
  yasps.energy @m::@p::@e
  yasps.minimize [@m::@p::@x]
}
