// RUN: yasps-opt %s -split-input-file -verify-diagnostics

// One case per verifier rule of the yasps dialect, each in its own split.

//===----------------------------------------------------------------------===//
// !yasps.mat
//===----------------------------------------------------------------------===//

// Matrix type: zero rows.
yasps.scene @s {
  // expected-error @+1 {{matrix shape must be at least 1x1, got 0x3}}
  yasps.const_attr @a : !yasps.mat<0x3xf64>
}

// -----

// Matrix type: zero columns.
yasps.scene @s {
  // expected-error @+1 {{matrix shape must be at least 1x1, got 2x0}}
  yasps.const_attr @a : !yasps.mat<2x0xf64>
}

// -----

// Matrix type: more entries than kernels can hold (found by fuzzing: the
// differentiation then aborted growing a vector of 2^32 entries).
yasps.scene @s {
  // expected-error @+1 {{matrix shape 4294967296x1 has more than the 16384 entries a yasps matrix may have}}
  yasps.const_attr @a : !yasps.mat<4294967296x1xf64>
}

// -----

// Matrix type: each side within the limit, the product not.
yasps.scene @s {
  // expected-error @+1 {{matrix shape 65536x65536 has more than the 16384 entries a yasps matrix may have}}
  yasps.const_attr @a : !yasps.mat<65536x65536xf64>
}

// -----

// Matrix type: the largest accepted.
yasps.scene @s {
  yasps.const_attr @a : !yasps.mat<128x128xf64>
}

// -----

// Matrix type: non-float element type.
yasps.scene @s {
  // expected-error @+1 {{expected f32 or f64 element type, got 'i32'}}
  yasps.const_attr @a : !yasps.mat<3x1xi32>
}

// -----

// Matrix type: float element type other than f32/f64.
yasps.scene @s {
  // expected-error @+1 {{matrix element type must be f32 or f64, got 'f16'}}
  yasps.const_attr @a : !yasps.mat<3x1xf16>
}

// -----

// Matrix type: rank 1.
yasps.scene @s {
  // expected-error @+1 {{expected rows x cols, got 1 dimension(s)}}
  yasps.const_attr @a : !yasps.mat<3xf64>
}

// -----

// Matrix type: rank 3.
yasps.scene @s {
  // expected-error @+1 {{expected rows x cols, got 3 dimension(s)}}
  yasps.const_attr @a : !yasps.mat<3x3x3xf64>
}

// -----

//===----------------------------------------------------------------------===//
// Scene
//===----------------------------------------------------------------------===//

// Scene: at most one yasps.minimize.
yasps.scene @s {
  yasps.data_attr @x : !yasps.mat<1x1xf64>
  yasps.data_attr @y : !yasps.mat<1x1xf64>
  yasps.minimize [@x]
  // expected-error @+1 {{'yasps.minimize' op scene @s already lists its minimisation targets; merge them into one 'yasps.minimize'}}
  yasps.minimize [@y]
}

// -----

// Structure nesting: a mesh must be directly inside a scene (HasParent).
// expected-error @+1 {{'yasps.mesh' op expects parent op 'yasps.scene'}}
yasps.mesh @m {
}

// -----

// Structure nesting: a primitive must be directly inside a mesh (HasParent).
yasps.scene @s {
  // expected-error @+1 {{'yasps.primitive' op expects parent op 'yasps.mesh'}}
  yasps.primitive @p(1) {
  }
}

// -----

// Structure nesting: a primitive union must be directly inside a mesh.
yasps.scene @s {
  // expected-error @+1 {{'yasps.primitive_union' op expects parent op 'yasps.mesh'}}
  yasps.primitive_union @u [@m::@p] {
  }
}

// -----

// Structure nesting: a connectivity must be directly inside a primitive.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
    }
    // expected-error @+1 {{'yasps.connectivity' op expects parent op 'yasps.primitive'}}
    yasps.connectivity @c -> @m::@p arity 1
  }
}

// -----

// Structure nesting: an attribute declaration must be owned by an entity.
// expected-error @+1 {{'yasps.data_attr' op expects parent op to be one of 'yasps.scene, yasps.mesh, yasps.primitive, yasps.primitive_union'}}
yasps.data_attr @x : !yasps.mat<1x1xf64>

// -----

// Structure nesting: energies are registered on the scene.
yasps.scene @s {
  yasps.mesh @m {
    yasps.const_attr @e : !yasps.mat<1x1xf64>
    // expected-error @+1 {{'yasps.energy' op expects parent op 'yasps.scene'}}
    yasps.energy @m::@e
  }
}

// -----

// Structure nesting: minimisation targets are listed on the scene.
yasps.scene @s {
  yasps.mesh @m {
    yasps.data_attr @x : !yasps.mat<1x1xf64>
    // expected-error @+1 {{'yasps.minimize' op expects parent op 'yasps.scene'}}
    yasps.minimize [@m::@x]
  }
}

// -----

// Symbols: two declarations of the same name in one entity.
yasps.scene @s {
  yasps.mesh @m {
    // expected-note @+1 {{see existing symbol definition here}}
    yasps.data_attr @x : !yasps.mat<1x1xf64>
    // expected-error @+1 {{redefinition of symbol named 'x'}}
    yasps.const_attr @x : !yasps.mat<1x1xf64>
  }
}

// -----

//===----------------------------------------------------------------------===//
// Primitive and primitive union
//===----------------------------------------------------------------------===//

// Primitive: negative instance count (IntNonNegative).
yasps.scene @s {
  yasps.mesh @m {
    // expected-error @+1 {{attribute 'num_instances' failed to satisfy constraint: 64-bit signless integer attribute whose value is non-negative}}
    yasps.primitive @p(-1) {
    }
  }
}

// -----

// Primitive union: no members.
yasps.scene @s {
  yasps.mesh @m {
    // expected-error @+1 {{primitive union @m::@u must have at least one member}}
    yasps.primitive_union @u [] {
    }
  }
}

// -----

// Primitive union: a member listed twice.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
    }
    // expected-error @+1 {{primitive union @m::@u lists member @m::@p twice}}
    yasps.primitive_union @u [@m::@p, @m::@p] {
    }
  }
}

// -----

// Primitive union: a member that is an attribute, not a primitive or union.
yasps.scene @s {
  yasps.mesh @m {
    yasps.const_attr @k : !yasps.mat<1x1xf64>
    // expected-error @+1 {{member @m::@k of primitive union @m::@u does not name a primitive or primitive union}}
    yasps.primitive_union @u [@m::@k] {
    }
  }
}

// -----

// Primitive union: a member that is a mesh.
yasps.scene @s {
  yasps.mesh @m {
    // expected-error @+1 {{member @m of primitive union @m::@u does not name a primitive or primitive union}}
    yasps.primitive_union @u [@m] {
    }
  }
}

// -----

// Primitive union: a member that does not resolve.
yasps.scene @s {
  yasps.mesh @m {
    // expected-error @+1 {{member @m::@missing of primitive union @m::@u does not name a primitive or primitive union}}
    yasps.primitive_union @u [@m::@missing] {
    }
  }
}

// -----

// Primitive union: lists itself directly.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
    }
    // expected-error @+1 {{primitive union @m::@u lists itself as a member}}
    yasps.primitive_union @u [@m::@p, @m::@u] {
    }
  }
}

// -----

// Primitive union: contains itself through another union.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
    }
    // expected-error @+1 {{primitive union @m::@u contains itself through primitive union @n::@w}}
    yasps.primitive_union @u [@m::@p, @n::@w] {
    }
  }
  yasps.mesh @n {
    yasps.primitive_union @w [@m::@u] {
    }
  }
}

// -----

// Primitive union: contains itself through a chain of two other unions.
yasps.scene @s {
  yasps.mesh @m {
    // expected-error @+1 {{primitive union @m::@a contains itself through primitive union @m::@b}}
    yasps.primitive_union @a [@m::@b] {
    }
    yasps.primitive_union @b [@m::@c] {
    }
    yasps.primitive_union @c [@m::@a] {
    }
  }
}

// -----

//===----------------------------------------------------------------------===//
// Connectivity
//===----------------------------------------------------------------------===//

// Connectivity: the target is an attribute, not a primitive or union.
yasps.scene @s {
  yasps.mesh @m {
    yasps.const_attr @k : !yasps.mat<1x1xf64>
    yasps.primitive @p(1) {
      // expected-error @+1 {{target @m::@k of connectivity @m::@p::@c does not name a primitive or primitive union}}
      yasps.connectivity @c -> @m::@k arity 1
    }
  }
}

// -----

// Connectivity: the target does not resolve.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      // expected-error @+1 {{target @m::@q of connectivity @m::@p::@c does not name a primitive or primitive union}}
      yasps.connectivity @c -> @m::@q arity 1
    }
  }
}

// -----

// Connectivity: arity 0 (IntPositive).
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      // expected-error @+1 {{attribute 'arity' failed to satisfy constraint: 64-bit signless integer attribute whose value is positive}}
      yasps.connectivity @c -> @m::@p arity 0
    }
  }
}

// -----

//===----------------------------------------------------------------------===//
// Computed attributes
//===----------------------------------------------------------------------===//

// Computed attribute: the region does not end in yasps.yield.
yasps.scene @s {
  // expected-error @+1 {{'yasps.attr' op computed attribute @a must end its region with 'yasps.yield'}}
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.identity : !yasps.mat<1x1xf64>
  }
}

// -----

// Computed attribute: the region has no block at all (SizedRegion<1>).
yasps.scene @s {
  // expected-error @+1 {{'yasps.attr' op region #0 ('body') failed to verify constraint: region with 1 blocks}}
  yasps.attr @a : !yasps.mat<1x1xf64> {
  }
}

// -----

// Yield: the yielded type differs from the declared type.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.yield' op yields '!yasps.mat<3x3xf64>' but computed attribute @a is declared '!yasps.mat<1x1xf64>'}}
    yasps.yield %0 : !yasps.mat<3x3xf64>
  }
}

// -----

// Yield: outside a computed attribute (HasParent); the value comes from a cast.
yasps.scene @s {
  %0 = builtin.unrealized_conversion_cast to !yasps.mat<1x1xf64>
  // expected-error @+1 {{'yasps.yield' op expects parent op 'yasps.attr'}}
  yasps.yield %0 : !yasps.mat<1x1xf64>
}

// -----

// Expression ops live only in computed attributes (HasParent).
yasps.scene @s {
  // expected-error @+1 {{'yasps.identity' op expects parent op 'yasps.attr'}}
  %0 = yasps.identity : !yasps.mat<3x3xf64>
}

// -----

// Lineage, deepest entity: an attribute on a primitive that reads only
// mesh and scene attributes belongs to the mesh.
yasps.scene @s {
  yasps.const_attr @dt : !yasps.mat<1x1xf64>
  yasps.mesh @m {
    yasps.const_attr @k : !yasps.mat<1x1xf64>
    yasps.primitive @p(1) {
      // expected-error @+1 {{'yasps.attr' op computed attribute @m::@p::@a is declared on primitive @m::@p but only reads attributes of its ancestors; the result belongs to the deepest entity it reads, mesh @m}}
      yasps.attr @a : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@k : !yasps.mat<1x1xf64>
        %1 = yasps.read @dt : !yasps.mat<1x1xf64>
        %2 = yasps.add %0, %1 : !yasps.mat<1x1xf64>
        yasps.yield %2 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Lineage, deepest entity: an attribute on a mesh that reads only scene
// attributes belongs to the scene.
yasps.scene @s {
  yasps.const_attr @dt : !yasps.mat<1x1xf64>
  yasps.mesh @m {
    // expected-error @+1 {{computed attribute @m::@a is declared on mesh @m but only reads attributes of its ancestors; the result belongs to the deepest entity it reads, scene @s}}
    yasps.attr @a : !yasps.mat<1x1xf64> {
      %0 = yasps.read @dt : !yasps.mat<1x1xf64>
      yasps.yield %0 : !yasps.mat<1x1xf64>
    }
  }
}

// -----

// Dependency cycle: a computed attribute that reads itself.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      // expected-error @+1 {{'yasps.attr' op computed attribute @m::@p::@a depends on itself}}
      yasps.attr @a : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@p::@a : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Dependency cycle: through reads of other computed attributes.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      // expected-error @+1 {{computed attribute @m::@p::@a depends on itself through computed attribute @m::@p::@b, computed attribute @m::@p::@c}}
      yasps.attr @a : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@p::@b : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
      yasps.attr @b : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@p::@c : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
      yasps.attr @c : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@p::@a : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Dependency cycle: through JOINs in both directions.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.connectivity @v2t -> @m::@t arity 1
      // expected-error @+1 {{computed attribute @m::@v::@x depends on itself through computed attribute @m::@t::@y}}
      yasps.attr @x : !yasps.mat<1x1xf64> {
        %0 = yasps.join @v2t(@m::@t::@y) : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
    yasps.primitive @t(1) {
      yasps.connectivity @t2v -> @m::@v arity 1
      yasps.attr @y : !yasps.mat<1x1xf64> {
        %0 = yasps.join @t2v(@m::@v::@x) : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Dependency cycle: through a UNION over the primitive that JOINs the union.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.connectivity @v2u -> @m::@u arity 1
      // expected-error @+1 {{computed attribute @m::@v::@x depends on itself through computed attribute @m::@u::@x}}
      yasps.attr @x : !yasps.mat<1x1xf64> {
        %0 = yasps.join @v2u(@m::@u::@x) : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
    yasps.primitive_union @u [@m::@v] {
      yasps.attr @x : !yasps.mat<1x1xf64> {
        %0 = yasps.union @x : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

//===----------------------------------------------------------------------===//
// Energy and minimize
//===----------------------------------------------------------------------===//

// Energy: names a primitive, not an attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
    }
  }
  // expected-error @+1 {{'yasps.energy' op energy @m::@p does not name an attribute}}
  yasps.energy @m::@p
}

// -----

// Energy: names nothing.
yasps.scene @s {
  // expected-error @+1 {{'yasps.energy' op energy @nothing does not name an attribute}}
  yasps.energy @nothing
}

// -----

// Energy: the attribute is not 1x1.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.const_attr @e : !yasps.mat<3x1xf64>
    }
  }
  // expected-error @+1 {{'yasps.energy' op energy constant attribute @m::@p::@e must be 1x1 per instance, got '!yasps.mat<3x1xf64>'}}
  yasps.energy @m::@p::@e
}

// -----

// Minimize: empty target list.
yasps.scene @s {
  // expected-error @+1 {{'yasps.minimize' op needs at least one minimisation target}}
  yasps.minimize []
}

// -----

// Minimize: a target that is not an attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
    }
  }
  // expected-error @+1 {{'yasps.minimize' op minimisation target @m::@p does not name an attribute}}
  yasps.minimize [@m::@p]
}

// -----

// Minimize: a constant attribute cannot be minimised.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.const_attr @x : !yasps.mat<3x1xf64>
    }
  }
  // expected-error @+1 {{'yasps.minimize' op minimisation target constant attribute @m::@p::@x is not a data attribute; only 'yasps.data_attr' attributes can be minimised}}
  yasps.minimize [@m::@p::@x]
}

// -----

// Minimize: a computed attribute cannot be minimised.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.attr @x : !yasps.mat<1x1xf64> {
        %0 = yasps.identity : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
  // expected-error @+1 {{'yasps.minimize' op minimisation target computed attribute @m::@p::@x is not a data attribute}}
  yasps.minimize [@m::@p::@x]
}

// -----

// Minimize: the same target twice.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
  }
  // expected-error @+1 {{'yasps.minimize' op minimisation target @m::@p::@x is listed twice}}
  yasps.minimize [@m::@p::@x, @m::@p::@x]
}

// -----

//===----------------------------------------------------------------------===//
// yasps.read
//===----------------------------------------------------------------------===//

// Read: an unknown symbol.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.attr @a : !yasps.mat<1x1xf64> {
        // expected-error @+1 {{'yasps.read' op @m::@p::@missing does not name an attribute in computed attribute @m::@p::@a}}
        %0 = yasps.read @m::@p::@missing : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Read: a symbol that is a connectivity, not an attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.connectivity @c -> @m::@p arity 1
      yasps.attr @a : !yasps.mat<1x1xf64> {
        // expected-error @+1 {{'yasps.read' op @m::@p::@c does not name an attribute in computed attribute @m::@p::@a}}
        %0 = yasps.read @m::@p::@c : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Read: the result type differs from the attribute's type.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @a : !yasps.mat<1x3xf64> {
        // expected-error @+1 {{'yasps.read' op reads data attribute @m::@p::@x as '!yasps.mat<1x3xf64>' but it is '!yasps.mat<3x1xf64>' in computed attribute @m::@p::@a}}
        %0 = yasps.read @m::@p::@x : !yasps.mat<1x3xf64>
        yasps.yield %0 : !yasps.mat<1x3xf64>
      }
    }
  }
}

// -----

// Read: an attribute of another primitive of the same mesh (off the lineage).
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @q(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @p(1) {
      yasps.attr @a : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.read' op reads data attribute @m::@q::@x of primitive @m::@q, which is not on the lineage of primitive @m::@p in computed attribute @m::@p::@a; use a JOIN through a connectivity or a UNION}}
        %0 = yasps.read @m::@q::@x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Read: an attribute of another mesh (off the lineage).
yasps.scene @s {
  yasps.mesh @n {
    yasps.const_attr @k : !yasps.mat<1x1xf64>
  }
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<1x1xf64>
      yasps.attr @a : !yasps.mat<1x1xf64> {
        %0 = yasps.read @m::@p::@x : !yasps.mat<1x1xf64>
        // expected-error @+1 {{'yasps.read' op reads constant attribute @n::@k of mesh @n, which is not on the lineage of primitive @m::@p}}
        %1 = yasps.read @n::@k : !yasps.mat<1x1xf64>
        %2 = yasps.add %0, %1 : !yasps.mat<1x1xf64>
        yasps.yield %2 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Read: a union reading an attribute of one of its members (off the lineage).
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive_union @u [@m::@p] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.read' op reads data attribute @m::@p::@x of primitive @m::@p, which is not on the lineage of primitive union @m::@u}}
        %0 = yasps.read @m::@p::@x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

//===----------------------------------------------------------------------===//
// yasps.join
//===----------------------------------------------------------------------===//

// Join: in a mesh-level attribute, which has no connectivity.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.attr @a : !yasps.mat<1x3xf64> {
      // expected-error @+1 {{'yasps.join' op JOIN needs a connectivity of a primitive, but computed attribute @m::@a is owned by mesh @m}}
      %0 = yasps.join @c(@m::@p::@x) : !yasps.mat<1x3xf64>
      yasps.yield %0 : !yasps.mat<1x3xf64>
    }
  }
}

// -----

// Join: in an attribute of a primitive union.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive_union @u [@m::@p] {
      yasps.attr @a : !yasps.mat<1x3xf64> {
        // expected-error @+1 {{'yasps.join' op JOIN needs a connectivity of a primitive, but computed attribute @m::@u::@a is owned by primitive union @m::@u}}
        %0 = yasps.join @c(@m::@p::@x) : !yasps.mat<1x3xf64>
        yasps.yield %0 : !yasps.mat<1x3xf64>
      }
    }
  }
}

// -----

// Join: in a scene-level attribute.
yasps.scene @s {
  yasps.const_attr @k : !yasps.mat<1x1xf64>
  yasps.attr @a : !yasps.mat<1x1xf64> {
    // expected-error @+1 {{'yasps.join' op JOIN needs a connectivity of a primitive, but computed attribute @a is owned by scene @s}}
    %0 = yasps.join @c(@k) : !yasps.mat<1x1xf64>
    yasps.yield %0 : !yasps.mat<1x1xf64>
  }
}

// -----

// Join: the owner has no connectivity of that name.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @a : !yasps.mat<2x3xf64> {
        // expected-error @+1 {{'yasps.join' op primitive @m::@e has no connectivity @missing in computed attribute @m::@e::@a}}
        %0 = yasps.join @missing(@m::@v::@x) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
    }
  }
}

// -----

// Join: the connectivity name resolves to an attribute, not a connectivity.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(1) {
      yasps.const_attr @k : !yasps.mat<1x1xf64>
      yasps.attr @a : !yasps.mat<2x3xf64> {
        // expected-error @+1 {{'yasps.join' op primitive @m::@e has no connectivity @k in computed attribute @m::@e::@a}}
        %0 = yasps.join @k(@m::@v::@x) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
    }
  }
}

// -----

// Join: the source names a primitive, not an attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @a : !yasps.mat<2x3xf64> {
        // expected-error @+1 {{'yasps.join' op JOIN source @m::@v does not name an attribute in computed attribute @m::@e::@a}}
        %0 = yasps.join @e2v(@m::@v) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
    }
  }
}

// -----

// Join: the source lives on another primitive than the connectivity's target.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @w(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @a : !yasps.mat<2x3xf64> {
        // expected-error @+1 {{'yasps.join' op JOIN source data attribute @m::@w::@x lives on primitive @m::@w but connectivity @m::@e::@e2v targets primitive @m::@v in computed attribute @m::@e::@a}}
        %0 = yasps.join @e2v(@m::@w::@x) : !yasps.mat<2x3xf64>
        yasps.yield %0 : !yasps.mat<2x3xf64>
      }
    }
  }
}

// -----

// Join: the source is a mesh attribute of the target's mesh, not of the target.
yasps.scene @s {
  yasps.mesh @m {
    yasps.const_attr @k : !yasps.mat<1x1xf64>
    yasps.primitive @v(1) {
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @a : !yasps.mat<2x1xf64> {
        // expected-error @+1 {{'yasps.join' op JOIN source constant attribute @m::@k lives on mesh @m but connectivity @m::@e::@e2v targets primitive @m::@v}}
        %0 = yasps.join @e2v(@m::@k) : !yasps.mat<2x1xf64>
        yasps.yield %0 : !yasps.mat<2x1xf64>
      }
    }
  }
}

// -----

// Join: a 3x3 source through an arity-4 connectivity is 4x9, not 4x3.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.data_attr @f : !yasps.mat<3x3xf64>
    }
    yasps.primitive @t(1) {
      yasps.connectivity @t2v -> @m::@v arity 4
      yasps.attr @a : !yasps.mat<4x3xf64> {
        // expected-error @+1 {{'yasps.join' op JOIN of '!yasps.mat<3x3xf64>' through arity-4 connectivity @m::@t::@t2v gives '!yasps.mat<4x9xf64>', not '!yasps.mat<4x3xf64>' in computed attribute @m::@t::@a}}
        %0 = yasps.join @t2v(@m::@v::@f) : !yasps.mat<4x3xf64>
        yasps.yield %0 : !yasps.mat<4x3xf64>
      }
    }
  }
}

// -----

// Join: the result keeps the source's element type.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(1) {
      yasps.connectivity @e2v -> @m::@v arity 2
      yasps.attr @a : !yasps.mat<2x3xf32> {
        // expected-error @+1 {{'yasps.join' op JOIN of '!yasps.mat<3x1xf64>' through arity-2 connectivity @m::@e::@e2v gives '!yasps.mat<2x3xf64>', not '!yasps.mat<2x3xf32>'}}
        %0 = yasps.join @e2v(@m::@v::@x) : !yasps.mat<2x3xf32>
        yasps.yield %0 : !yasps.mat<2x3xf32>
      }
    }
  }
}

// -----

//===----------------------------------------------------------------------===//
// yasps.union
//===----------------------------------------------------------------------===//

// Union: in an attribute of a plain primitive.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.attr @a : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.union' op UNION must be in an attribute of a primitive union, not of primitive @m::@p in computed attribute @m::@p::@a}}
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Union: in a mesh-level attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.attr @a : !yasps.mat<3x1xf64> {
      // expected-error @+1 {{'yasps.union' op UNION must be in an attribute of a primitive union, not of mesh @m in computed attribute @m::@a}}
      %0 = yasps.union @x : !yasps.mat<3x1xf64>
      yasps.yield %0 : !yasps.mat<3x1xf64>
    }
  }
}

// -----

// Union: a member lacks the attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @q(1) {
      yasps.data_attr @y : !yasps.mat<3x1xf64>
    }
    yasps.primitive_union @u [@m::@p, @m::@q] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.union' op UNION member primitive @m::@q has no attribute @x in computed attribute @m::@u::@x}}
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Union: a member has a symbol of that name that is not an attribute.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.connectivity @x -> @m::@p arity 1
    }
    yasps.primitive_union @u [@m::@p] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.union' op UNION member primitive @m::@p has no attribute @x}}
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Union: a member's attribute has another shape.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @q(1) {
      yasps.data_attr @x : !yasps.mat<1x3xf64>
    }
    yasps.primitive_union @u [@m::@p, @m::@q] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.union' op UNION member data attribute @m::@q::@x is '!yasps.mat<1x3xf64>' but the union reads '!yasps.mat<3x1xf64>' in computed attribute @m::@u::@x}}
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Union: a member's attribute has another element type.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.data_attr @x : !yasps.mat<3x1xf32>
    }
    yasps.primitive_union @u [@m::@p] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{'yasps.union' op UNION member data attribute @m::@p::@x is '!yasps.mat<3x1xf32>' but the union reads '!yasps.mat<3x1xf64>'}}
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

//===----------------------------------------------------------------------===//
// Constants
//===----------------------------------------------------------------------===//

// Constant: a 1-D literal.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    // expected-error @+1 {{'yasps.constant' needs a 2-D float tensor literal such as dense<1.0> : tensor<1x1xf64>}}
    %0 = yasps.constant dense<1.0> : tensor<3xf64>
    yasps.yield %0 : !yasps.mat<3x1xf64>
  }
}

// -----

// Constant: an integer literal.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    // expected-error @+1 {{'yasps.constant' needs a 2-D float tensor literal}}
    %0 = yasps.constant dense<1> : tensor<1x1xi32>
    yasps.yield %0 : !yasps.mat<1x1xf64>
  }
}

// -----

// Constant: a float literal that is neither f32 nor f64.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    // expected-error @+1 {{'yasps.constant' needs a non-empty f32 or f64 literal, got 'tensor<1x1xf16>'}}
    %0 = yasps.constant dense<1.0> : tensor<1x1xf16>
    yasps.yield %0 : !yasps.mat<1x1xf64>
  }
}

// -----

// Constant: an empty literal.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    // expected-error @+1 {{'yasps.constant' needs a non-empty f32 or f64 literal, got 'tensor<0x1xf64>'}}
    %0 = yasps.constant dense<> : tensor<0x1xf64>
    yasps.yield %0 : !yasps.mat<1x1xf64>
  }
}

// -----

// Constant: a float literal that is not dense.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    // expected-error @+1 {{'yasps.constant' op needs a dense float literal in computed attribute @a}}
    %0 = yasps.constant sparse<[[0, 0]], [1.0]> : tensor<1x1xf64>
    yasps.yield %0 : !yasps.mat<1x1xf64>
  }
}

// -----

// Constant: the result type differs from the literal's shape (InferTypeOpInterface).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x2xf64> {
    // expected-error @+2 {{'yasps.constant' op inferred type(s) '!yasps.mat<1x1xf64>' are incompatible with return type(s) of operation '!yasps.mat<2x2xf64>'}}
    // expected-error @+1 {{'yasps.constant' op failed to infer returned types}}
    %0 = "yasps.constant"() <{value = dense<1.0> : tensor<1x1xf64>}> : () -> !yasps.mat<2x2xf64>
    yasps.yield %0 : !yasps.mat<2x2xf64>
  }
}

// -----

// Identity: not square.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x3xf64> {
    // expected-error @+1 {{'yasps.identity' op needs a square matrix, got '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %0 = yasps.identity : !yasps.mat<2x3xf64>
    yasps.yield %0 : !yasps.mat<2x3xf64>
  }
}

// -----

//===----------------------------------------------------------------------===//
// Elementwise ops
//===----------------------------------------------------------------------===//

// Add: operands of different shapes (SameOperandsAndResultType).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x3xf64>
    // expected-error @+1 {{'yasps.add' op requires the same type for all operands and results}}
    %2 = "yasps.add"(%0, %1) : (!yasps.mat<3x1xf64>, !yasps.mat<1x3xf64>) -> !yasps.mat<3x1xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Neg: result type differs from the operand's (SameOperandsAndResultType).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf32> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.neg' op requires the same type for all operands and results}}
    %1 = "yasps.neg"(%0) : (!yasps.mat<3x1xf64>) -> !yasps.mat<3x1xf32>
    yasps.yield %1 : !yasps.mat<3x1xf32>
  }
}

// -----

// Pow: the exponent is neither 1x1 nor the base's shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<2.0> : tensor<1x3xf64>
    // expected-error @+1 {{'yasps.pow' op exponent must be 1x1 or the base's shape '!yasps.mat<3x1xf64>', got '!yasps.mat<1x3xf64>' in computed attribute @a}}
    %2 = yasps.pow %0, %1 : !yasps.mat<3x1xf64>, !yasps.mat<1x3xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Pow: mixed element types f64 and f32.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<2.0> : tensor<1x1xf32>
    // expected-error @+1 {{'yasps.pow' op mixes element types '!yasps.mat<3x1xf64>' and '!yasps.mat<1x1xf32>' in computed attribute @a}}
    %2 = yasps.pow %0, %1 : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf32>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Pow: result type differs from the base (AllTypesMatch).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x3xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<2.0> : tensor<1x1xf64>
    // expected-error @+1 {{'yasps.pow' op failed to verify that all of {base, result} have same type}}
    %2 = "yasps.pow"(%0, %1) : (!yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>) -> !yasps.mat<1x3xf64>
    yasps.yield %2 : !yasps.mat<1x3xf64>
  }
}

// -----

// Select: the condition is neither 1x1 nor the values' shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %c = yasps.constant dense<1.0> : tensor<1x3xf64>
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.select' op condition must be 1x1 or the values' shape '!yasps.mat<3x1xf64>', got '!yasps.mat<1x3xf64>' in computed attribute @a}}
    %1 = yasps.select %c, %0, %0 : !yasps.mat<1x3xf64>, !yasps.mat<3x1xf64>
    yasps.yield %1 : !yasps.mat<3x1xf64>
  }
}

// -----

// Select: the condition's element type differs from the values'.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %c = yasps.constant dense<1.0> : tensor<1x1xf32>
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.select' op mixes element types '!yasps.mat<1x1xf32>' and '!yasps.mat<3x1xf64>'}}
    %1 = yasps.select %c, %0, %0 : !yasps.mat<1x1xf32>, !yasps.mat<3x1xf64>
    yasps.yield %1 : !yasps.mat<3x1xf64>
  }
}

// -----

// Select: true and false values of different types (AllTypesMatch).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %c = yasps.constant dense<1.0> : tensor<1x1xf64>
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x3xf64>
    // expected-error @+1 {{'yasps.select' op failed to verify that all of {true_value, false_value, result} have same type}}
    %2 = "yasps.select"(%c, %0, %1) : (!yasps.mat<1x1xf64>, !yasps.mat<3x1xf64>, !yasps.mat<1x3xf64>) -> !yasps.mat<3x1xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Cmp: operands of different shapes (SameOperandsAndResultType).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x1xf64>
    // expected-error @+1 {{'yasps.cmp' op requires the same type for all operands and results}}
    %2 = "yasps.cmp"(%0, %1) <{predicate = 0 : i32}> : (!yasps.mat<3x1xf64>, !yasps.mat<1x1xf64>) -> !yasps.mat<3x1xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

//===----------------------------------------------------------------------===//
// Scalar scaling and matrix algebra
//===----------------------------------------------------------------------===//

// Scale: the right-hand side is not 1x1.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.scale' op needs a 1x1 scalar on the right, got '!yasps.mat<3x1xf64>' (with '!yasps.mat<3x1xf64>') in computed attribute @a}}
    %1 = yasps.scale %0, %0 : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>
    yasps.yield %1 : !yasps.mat<3x1xf64>
  }
}

// -----

// Scale: mixed element types f64 and f32.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x1xf32>
    // expected-error @+1 {{'yasps.scale' op mixes element types '!yasps.mat<3x1xf64>' and '!yasps.mat<1x1xf32>' in computed attribute @a}}
    %2 = yasps.scale %0, %1 : !yasps.mat<3x1xf64>, !yasps.mat<1x1xf32>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Div: the right-hand side is not 1x1.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<2.0> : tensor<1x3xf64>
    // expected-error @+1 {{'yasps.div' op needs a 1x1 scalar on the right, got '!yasps.mat<1x3xf64>' (with '!yasps.mat<3x1xf64>') in computed attribute @a}}
    %2 = yasps.div %0, %1 : !yasps.mat<3x1xf64>, !yasps.mat<1x3xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Div: mixed element types f32 and f64.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf32> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf32>
    %1 = yasps.constant dense<2.0> : tensor<1x1xf64>
    // expected-error @+1 {{'yasps.div' op mixes element types '!yasps.mat<3x1xf32>' and '!yasps.mat<1x1xf64>'}}
    %2 = yasps.div %0, %1 : !yasps.mat<3x1xf32>, !yasps.mat<1x1xf64>
    yasps.yield %2 : !yasps.mat<3x1xf32>
  }
}

// -----

// Matmul: inner dimensions differ.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    %1 = yasps.constant dense<1.0> : tensor<2x1xf64>
    // expected-error @+1 {{'yasps.matmul' op cannot multiply '!yasps.mat<3x3xf64>' by '!yasps.mat<2x1xf64>': inner dimensions 3 and 2 differ in computed attribute @a}}
    %2 = yasps.matmul %0, %1 : !yasps.mat<3x3xf64>, !yasps.mat<2x1xf64> -> !yasps.mat<3x1xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Matmul: wrong result shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x3xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    %1 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.matmul' op matrix product gives '!yasps.mat<3x1xf64>', not '!yasps.mat<1x3xf64>' in computed attribute @a}}
    %2 = yasps.matmul %0, %1 : !yasps.mat<3x3xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<1x3xf64>
    yasps.yield %2 : !yasps.mat<1x3xf64>
  }
}

// -----

// Matmul: mixed element types f32 and f64.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf32>
    %1 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.matmul' op mixes element types '!yasps.mat<3x3xf32>' and '!yasps.mat<3x1xf64>'}}
    %2 = yasps.matmul %0, %1 : !yasps.mat<3x3xf32>, !yasps.mat<3x1xf64> -> !yasps.mat<3x1xf64>
    yasps.yield %2 : !yasps.mat<3x1xf64>
  }
}

// -----

// Transpose: wrong result shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x2xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x2xf64>
    // expected-error @+1 {{'yasps.transpose' op transpose gives '!yasps.mat<2x3xf64>', not '!yasps.mat<3x2xf64>' in computed attribute @a}}
    %1 = yasps.transpose %0 : !yasps.mat<3x2xf64> -> !yasps.mat<3x2xf64>
    yasps.yield %1 : !yasps.mat<3x2xf64>
  }
}

// -----

// Transpose: the result changes the element type.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x3xf32> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.transpose' op transpose gives '!yasps.mat<1x3xf64>', not '!yasps.mat<1x3xf32>'}}
    %1 = yasps.transpose %0 : !yasps.mat<3x1xf64> -> !yasps.mat<1x3xf32>
    yasps.yield %1 : !yasps.mat<1x3xf32>
  }
}

// -----

// Dot: operands of different shapes (AllTypesMatch).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x3xf64>
    // expected-error @+1 {{'yasps.dot' op failed to verify that all of {lhs, rhs} have same type}}
    %2 = "yasps.dot"(%0, %1) : (!yasps.mat<3x1xf64>, !yasps.mat<1x3xf64>) -> !yasps.mat<1x1xf64>
    yasps.yield %2 : !yasps.mat<1x1xf64>
  }
}

// -----

// Dot: the result is not 1x1 (TypesMatchWith).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.dot' op failed to verify that result is the 1x1 matrix of the operand's element type}}
    %1 = "yasps.dot"(%0, %0) : (!yasps.mat<3x1xf64>, !yasps.mat<3x1xf64>) -> !yasps.mat<3x1xf64>
    yasps.yield %1 : !yasps.mat<3x1xf64>
  }
}

// -----

// Cross: the operands are not 3-vectors.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x1xf64>
    // expected-error @+1 {{'yasps.cross' op needs 3x1 or 1x3 vectors, got '!yasps.mat<2x1xf64>' in computed attribute @a}}
    %1 = yasps.cross %0, %0 : !yasps.mat<2x1xf64>
    yasps.yield %1 : !yasps.mat<2x1xf64>
  }
}

// -----

// Cross: a 3x3 matrix is not a 3-vector.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x3xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.cross' op needs 3x1 or 1x3 vectors, got '!yasps.mat<3x3xf64>'}}
    %1 = yasps.cross %0, %0 : !yasps.mat<3x3xf64>
    yasps.yield %1 : !yasps.mat<3x3xf64>
  }
}

// -----

// Det: not square.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.det' op needs a square matrix, got '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.det %0 : !yasps.mat<2x3xf64>
    yasps.yield %1 : !yasps.mat<1x1xf64>
  }
}

// -----

// Trace: not square.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x2xf64>
    // expected-error @+1 {{'yasps.trace' op needs a square matrix, got '!yasps.mat<3x2xf64>' in computed attribute @a}}
    %1 = yasps.trace %0 : !yasps.mat<3x2xf64>
    yasps.yield %1 : !yasps.mat<1x1xf64>
  }
}

// -----

// Singular value sum: not square.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x2xf64>
    // expected-error @+1 {{'yasps.singular_value_sum' op needs a square matrix, got '!yasps.mat<3x2xf64>' in computed attribute @a}}
    %1 = yasps.singular_value_sum %0 : !yasps.mat<3x2xf64>
    yasps.yield %1 : !yasps.mat<1x1xf64>
  }
}

// -----

// Singular value sum: larger than 3x3.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<4x4xf64>
    // expected-error @+1 {{'yasps.singular_value_sum' op needs a matrix of at most 3x3, got '!yasps.mat<4x4xf64>' in computed attribute @a}}
    %1 = yasps.singular_value_sum %0 : !yasps.mat<4x4xf64>
    yasps.yield %1 : !yasps.mat<1x1xf64>
  }
}

// -----

// Norm: the result is not 1x1 (TypesMatchWith).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.norm' op failed to verify that result is the 1x1 matrix of the operand's element type}}
    %1 = "yasps.norm"(%0) : (!yasps.mat<3x1xf64>) -> !yasps.mat<3x1xf64>
    yasps.yield %1 : !yasps.mat<3x1xf64>
  }
}

// -----

// Inverse: not square.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x3xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.inverse' op needs a square matrix, got '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.inverse %0 : !yasps.mat<2x3xf64>
    yasps.yield %1 : !yasps.mat<2x3xf64>
  }
}

// -----

// Project: not square.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x3xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.project' op needs a square matrix, got '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.project clamp %0 : !yasps.mat<2x3xf64>
    yasps.yield %1 : !yasps.mat<2x3xf64>
  }
}

// -----

//===----------------------------------------------------------------------===//
// Extracting and rearranging entries
//===----------------------------------------------------------------------===//

// Row: index out of range.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x3xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.row' op row 2 is out of range for '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.row %0[2] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
    yasps.yield %1 : !yasps.mat<1x3xf64>
  }
}

// -----

// Row: negative index (IntNonNegative).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x3xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{attribute 'index' failed to satisfy constraint: 64-bit signless integer attribute whose value is non-negative}}
    %1 = yasps.row %0[-1] : !yasps.mat<2x3xf64> -> !yasps.mat<1x3xf64>
    yasps.yield %1 : !yasps.mat<1x3xf64>
  }
}

// -----

// Row: wrong result shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.row' op a row gives '!yasps.mat<1x3xf64>', not '!yasps.mat<3x1xf64>' in computed attribute @a}}
    %1 = yasps.row %0[1] : !yasps.mat<2x3xf64> -> !yasps.mat<3x1xf64>
    yasps.yield %1 : !yasps.mat<3x1xf64>
  }
}

// -----

// Col: index out of range.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.col' op column 3 is out of range for '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.col %0[3] : !yasps.mat<2x3xf64> -> !yasps.mat<2x1xf64>
    yasps.yield %1 : !yasps.mat<2x1xf64>
  }
}

// -----

// Col: wrong result shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x2xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.col' op a column gives '!yasps.mat<2x1xf64>', not '!yasps.mat<1x2xf64>' in computed attribute @a}}
    %1 = yasps.col %0[0] : !yasps.mat<2x3xf64> -> !yasps.mat<1x2xf64>
    yasps.yield %1 : !yasps.mat<1x2xf64>
  }
}

// -----

// Element: row index out of range.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.element' op row 2 is out of range for '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.element %0[2, 0] : !yasps.mat<2x3xf64>
    yasps.yield %1 : !yasps.mat<1x1xf64>
  }
}

// -----

// Element: column index out of range.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.element' op column 3 is out of range for '!yasps.mat<2x3xf64>' in computed attribute @a}}
    %1 = yasps.element %0[1, 3] : !yasps.mat<2x3xf64>
    yasps.yield %1 : !yasps.mat<1x1xf64>
  }
}

// -----

// Element: the result is not 1x1 (TypesMatchWith).
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x3xf64> {
    %0 = yasps.constant dense<1.0> : tensor<2x3xf64>
    // expected-error @+1 {{'yasps.element' op failed to verify that result is the 1x1 matrix of the operand's element type}}
    %1 = "yasps.element"(%0) <{row = 0 : i64, col = 0 : i64}> : (!yasps.mat<2x3xf64>) -> !yasps.mat<1x3xf64>
    yasps.yield %1 : !yasps.mat<1x3xf64>
  }
}

// -----

// Slice: the block does not fit.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x2xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.slice' op block of '!yasps.mat<2x2xf64>' at (2, 0) does not fit in '!yasps.mat<3x3xf64>' in computed attribute @a}}
    %1 = yasps.slice %0[2, 0] : !yasps.mat<3x3xf64> -> !yasps.mat<2x2xf64>
    yasps.yield %1 : !yasps.mat<2x2xf64>
  }
}

// -----

// Slice: the block is wider than the matrix.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x4xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.slice' op block of '!yasps.mat<1x4xf64>' at (0, 0) does not fit in '!yasps.mat<3x3xf64>'}}
    %1 = yasps.slice %0[0, 0] : !yasps.mat<3x3xf64> -> !yasps.mat<1x4xf64>
    yasps.yield %1 : !yasps.mat<1x4xf64>
  }
}

// -----

// Slice: the result changes the element type.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x2xf32> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.slice' op mixes element types '!yasps.mat<3x3xf64>' and '!yasps.mat<2x2xf32>'}}
    %1 = yasps.slice %0[0, 0] : !yasps.mat<3x3xf64> -> !yasps.mat<2x2xf32>
    yasps.yield %1 : !yasps.mat<2x2xf32>
  }
}

// -----

// Resize: the element count changes.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x4xf64> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.resize' op cannot resize '!yasps.mat<3x3xf64>' to '!yasps.mat<2x4xf64>': 9 vs 8 entries in computed attribute @a}}
    %1 = yasps.resize %0 : !yasps.mat<3x3xf64> -> !yasps.mat<2x4xf64>
    yasps.yield %1 : !yasps.mat<2x4xf64>
  }
}

// -----

// Resize: the result changes the element type.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x9xf32> {
    %0 = yasps.identity : !yasps.mat<3x3xf64>
    // expected-error @+1 {{'yasps.resize' op mixes element types '!yasps.mat<3x3xf64>' and '!yasps.mat<1x9xf32>'}}
    %1 = yasps.resize %0 : !yasps.mat<3x3xf64> -> !yasps.mat<1x9xf32>
    yasps.yield %1 : !yasps.mat<1x9xf32>
  }
}

// -----

// Concat: vertical concatenation of matrices with different column counts.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<4x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x3xf64>
    // expected-error @+1 {{'yasps.concat' op vertical concatenation needs equal column counts, got '!yasps.mat<3x1xf64>' and '!yasps.mat<1x3xf64>' in computed attribute @a}}
    %2 = yasps.concat vertical %0, %1 : !yasps.mat<3x1xf64>, !yasps.mat<1x3xf64> -> !yasps.mat<4x1xf64>
    yasps.yield %2 : !yasps.mat<4x1xf64>
  }
}

// -----

// Concat: horizontal concatenation of matrices with different row counts.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x2xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<2x1xf64>
    // expected-error @+1 {{'yasps.concat' op horizontal concatenation needs equal row counts, got '!yasps.mat<3x1xf64>' and '!yasps.mat<2x1xf64>' in computed attribute @a}}
    %2 = yasps.concat horizontal %0, %1 : !yasps.mat<3x1xf64>, !yasps.mat<2x1xf64> -> !yasps.mat<3x2xf64>
    yasps.yield %2 : !yasps.mat<3x2xf64>
  }
}

// -----

// Concat: wrong result shape.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<3x2xf64> {
    %0 = yasps.constant dense<1.0> : tensor<3x1xf64>
    // expected-error @+1 {{'yasps.concat' op concatenation gives '!yasps.mat<6x1xf64>', not '!yasps.mat<3x2xf64>' in computed attribute @a}}
    %1 = yasps.concat vertical %0, %0 : !yasps.mat<3x1xf64>, !yasps.mat<3x1xf64> -> !yasps.mat<3x2xf64>
    yasps.yield %1 : !yasps.mat<3x2xf64>
  }
}

// -----

// Concat: mixed element types f64 and f32.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<2x1xf64> {
    %0 = yasps.constant dense<1.0> : tensor<1x1xf64>
    %1 = yasps.constant dense<1.0> : tensor<1x1xf32>
    // expected-error @+1 {{'yasps.concat' op mixes element types '!yasps.mat<1x1xf64>' and '!yasps.mat<1x1xf32>'}}
    %2 = yasps.concat vertical %0, %1 : !yasps.mat<1x1xf64>, !yasps.mat<1x1xf32> -> !yasps.mat<2x1xf64>
    yasps.yield %2 : !yasps.mat<2x1xf64>
  }
}

// -----

// Concat: no operand at all.
yasps.scene @s {
  yasps.attr @a : !yasps.mat<1x1xf64> {
    // expected-error @+1 {{'yasps.concat' op needs at least one operand in computed attribute @a}}
    %0 = "yasps.concat"() <{axis = 0 : i32}> : () -> !yasps.mat<1x1xf64>
    yasps.yield %0 : !yasps.mat<1x1xf64>
  }
}

//===----------------------------------------------------------------------===//
// Rules added after review
//===----------------------------------------------------------------------===//

// -----

// Primitive union: a member that is not an entity is reported as such, even
// when an attribute of the union reads it through a UNION.
yasps.scene @s {
  yasps.mesh @m {
    yasps.data_attr @k : !yasps.mat<3x1xf64>
    // expected-error @+1 {{member @m::@k of primitive union @m::@u does not name a primitive or primitive union}}
    yasps.primitive_union @u [@m::@k] {
      yasps.attr @x : !yasps.mat<3x1xf64> {
        %0 = yasps.union @x : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Computed attribute: no region arguments.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      // expected-error @+1 {{computed attribute @m::@p::@a must not have region arguments}}
      yasps.attr @a : !yasps.mat<1x1xf64> {
      ^bb0(%arg0: !yasps.mat<1x1xf64>):
        yasps.yield %arg0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Computed attribute: only yasps ops in the region.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      yasps.attr @a : !yasps.mat<1x1xf64> {
        // expected-error @+1 {{is not a yasps expression; computed attribute @m::@p::@a may only contain yasps ops}}
        %0 = builtin.unrealized_conversion_cast to !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
}

// -----

// Scene: only at module level.
yasps.scene @outer {
  // expected-error @+1 {{expects parent op 'builtin.module'}}
  yasps.scene @inner {
  }
}

// -----

// Reads are checked before the attribute-level rules: the type mismatch is
// what gets reported, not the deepest-entity rule it leads to.
yasps.scene @s {
  yasps.mesh @m {
    yasps.data_attr @k : !yasps.mat<1x1xf64>
    yasps.primitive @p(1) {
      yasps.attr @a : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{reads data attribute @m::@k as '!yasps.mat<3x1xf64>' but it is '!yasps.mat<1x1xf64>'}}
        %0 = yasps.read @m::@k : !yasps.mat<3x1xf64>
        yasps.yield %0 : !yasps.mat<3x1xf64>
      }
    }
  }
}

// -----

// Energy: on a dynamic primitive, needs dynamic_instances.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @pp(0) dynamic {
      yasps.data_attr @e : !yasps.mat<1x1xf64>
    }
  }
  // expected-error @+1 {{energy data attribute @m::@pp::@e is on primitive @m::@pp, whose instances change at run time; register it with 'dynamic_instances'}}
  yasps.energy @m::@pp::@e
}

// -----

// Energy: on a union with a dynamic member, needs dynamic_instances.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @a(2) {
      yasps.data_attr @e : !yasps.mat<1x1xf64>
    }
    yasps.primitive @b(0) dynamic {
      yasps.data_attr @e : !yasps.mat<1x1xf64>
    }
    yasps.primitive_union @u [@m::@a, @m::@b] {
      yasps.attr @e : !yasps.mat<1x1xf64> {
        %0 = yasps.union @e : !yasps.mat<1x1xf64>
        yasps.yield %0 : !yasps.mat<1x1xf64>
      }
    }
  }
  // expected-error @+1 {{energy computed attribute @m::@u::@e is on primitive union @m::@u, whose instances change at run time}}
  yasps.energy @m::@u::@e
}

// -----

// Energy: dynamic_instances on a static primitive.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(3) {
      yasps.data_attr @e : !yasps.mat<1x1xf64>
    }
  }
  // expected-error @+1 {{energy data attribute @m::@p::@e is marked 'dynamic_instances' but primitive @m::@p is not dynamic}}
  yasps.energy @m::@p::@e dynamic_instances
}

// -----

// Energy: registered twice.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(3) {
      yasps.data_attr @e : !yasps.mat<1x1xf64>
    }
  }
  yasps.energy @m::@p::@e
  // expected-error @+1 {{energy data attribute @m::@p::@e is registered twice}}
  yasps.energy @m::@p::@e
}

// -----

// DoF numbers of an attribute that is not a minimisation target.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(2) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
      yasps.data_attr @y : !yasps.mat<3x1xf64>
      yasps.attr @i : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{data attribute @m::@v::@y is not a minimisation target (yasps.minimize), so its entries have no DoF numbers}}
        %i = yasps.dof_index @m::@v::@y : !yasps.mat<3x1xf64>
        yasps.yield %i : !yasps.mat<3x1xf64>
      }
    }
  }
  yasps.minimize [@m::@v::@x]
}

// -----

// DoF numbers come as a column of the target's entries.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(2) {
      yasps.data_attr @x : !yasps.mat<3x2xf64>
      yasps.attr @i : !yasps.mat<3x2xf64> {
        // expected-error @+1 {{the DoF numbers of data attribute @m::@v::@x ('!yasps.mat<3x2xf64>') form a '!yasps.mat<6x1xf64>', not a '!yasps.mat<3x2xf64>'}}
        %i = yasps.dof_index @m::@v::@x : !yasps.mat<3x2xf64>
        yasps.yield %i : !yasps.mat<3x2xf64>
      }
    }
  }
  yasps.minimize [@m::@v::@x]
}

// -----

// DoF numbers of a target on another primitive need a JOIN.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @v(2) {
      yasps.data_attr @x : !yasps.mat<3x1xf64>
    }
    yasps.primitive @e(1) {
      yasps.attr @i : !yasps.mat<3x1xf64> {
        // expected-error @+1 {{numbers the DoFs of data attribute @m::@v::@x of primitive @m::@v, which is not on the lineage of primitive @m::@e}}
        %i = yasps.dof_index @m::@v::@x : !yasps.mat<3x1xf64>
        yasps.yield %i : !yasps.mat<3x1xf64>
      }
    }
  }
  yasps.minimize [@m::@v::@x]
}

// -----

// Primitive union: past the 256 members a kernel decodes.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p0(1) {
    }
    yasps.primitive @p1(1) {
    }
    yasps.primitive @p2(1) {
    }
    yasps.primitive @p3(1) {
    }
    yasps.primitive @p4(1) {
    }
    yasps.primitive @p5(1) {
    }
    yasps.primitive @p6(1) {
    }
    yasps.primitive @p7(1) {
    }
    yasps.primitive @p8(1) {
    }
    yasps.primitive @p9(1) {
    }
    yasps.primitive @p10(1) {
    }
    yasps.primitive @p11(1) {
    }
    yasps.primitive @p12(1) {
    }
    yasps.primitive @p13(1) {
    }
    yasps.primitive @p14(1) {
    }
    yasps.primitive @p15(1) {
    }
    yasps.primitive @p16(1) {
    }
    yasps.primitive @p17(1) {
    }
    yasps.primitive @p18(1) {
    }
    yasps.primitive @p19(1) {
    }
    yasps.primitive @p20(1) {
    }
    yasps.primitive @p21(1) {
    }
    yasps.primitive @p22(1) {
    }
    yasps.primitive @p23(1) {
    }
    yasps.primitive @p24(1) {
    }
    yasps.primitive @p25(1) {
    }
    yasps.primitive @p26(1) {
    }
    yasps.primitive @p27(1) {
    }
    yasps.primitive @p28(1) {
    }
    yasps.primitive @p29(1) {
    }
    yasps.primitive @p30(1) {
    }
    yasps.primitive @p31(1) {
    }
    yasps.primitive @p32(1) {
    }
    yasps.primitive @p33(1) {
    }
    yasps.primitive @p34(1) {
    }
    yasps.primitive @p35(1) {
    }
    yasps.primitive @p36(1) {
    }
    yasps.primitive @p37(1) {
    }
    yasps.primitive @p38(1) {
    }
    yasps.primitive @p39(1) {
    }
    yasps.primitive @p40(1) {
    }
    yasps.primitive @p41(1) {
    }
    yasps.primitive @p42(1) {
    }
    yasps.primitive @p43(1) {
    }
    yasps.primitive @p44(1) {
    }
    yasps.primitive @p45(1) {
    }
    yasps.primitive @p46(1) {
    }
    yasps.primitive @p47(1) {
    }
    yasps.primitive @p48(1) {
    }
    yasps.primitive @p49(1) {
    }
    yasps.primitive @p50(1) {
    }
    yasps.primitive @p51(1) {
    }
    yasps.primitive @p52(1) {
    }
    yasps.primitive @p53(1) {
    }
    yasps.primitive @p54(1) {
    }
    yasps.primitive @p55(1) {
    }
    yasps.primitive @p56(1) {
    }
    yasps.primitive @p57(1) {
    }
    yasps.primitive @p58(1) {
    }
    yasps.primitive @p59(1) {
    }
    yasps.primitive @p60(1) {
    }
    yasps.primitive @p61(1) {
    }
    yasps.primitive @p62(1) {
    }
    yasps.primitive @p63(1) {
    }
    yasps.primitive @p64(1) {
    }
    yasps.primitive @p65(1) {
    }
    yasps.primitive @p66(1) {
    }
    yasps.primitive @p67(1) {
    }
    yasps.primitive @p68(1) {
    }
    yasps.primitive @p69(1) {
    }
    yasps.primitive @p70(1) {
    }
    yasps.primitive @p71(1) {
    }
    yasps.primitive @p72(1) {
    }
    yasps.primitive @p73(1) {
    }
    yasps.primitive @p74(1) {
    }
    yasps.primitive @p75(1) {
    }
    yasps.primitive @p76(1) {
    }
    yasps.primitive @p77(1) {
    }
    yasps.primitive @p78(1) {
    }
    yasps.primitive @p79(1) {
    }
    yasps.primitive @p80(1) {
    }
    yasps.primitive @p81(1) {
    }
    yasps.primitive @p82(1) {
    }
    yasps.primitive @p83(1) {
    }
    yasps.primitive @p84(1) {
    }
    yasps.primitive @p85(1) {
    }
    yasps.primitive @p86(1) {
    }
    yasps.primitive @p87(1) {
    }
    yasps.primitive @p88(1) {
    }
    yasps.primitive @p89(1) {
    }
    yasps.primitive @p90(1) {
    }
    yasps.primitive @p91(1) {
    }
    yasps.primitive @p92(1) {
    }
    yasps.primitive @p93(1) {
    }
    yasps.primitive @p94(1) {
    }
    yasps.primitive @p95(1) {
    }
    yasps.primitive @p96(1) {
    }
    yasps.primitive @p97(1) {
    }
    yasps.primitive @p98(1) {
    }
    yasps.primitive @p99(1) {
    }
    yasps.primitive @p100(1) {
    }
    yasps.primitive @p101(1) {
    }
    yasps.primitive @p102(1) {
    }
    yasps.primitive @p103(1) {
    }
    yasps.primitive @p104(1) {
    }
    yasps.primitive @p105(1) {
    }
    yasps.primitive @p106(1) {
    }
    yasps.primitive @p107(1) {
    }
    yasps.primitive @p108(1) {
    }
    yasps.primitive @p109(1) {
    }
    yasps.primitive @p110(1) {
    }
    yasps.primitive @p111(1) {
    }
    yasps.primitive @p112(1) {
    }
    yasps.primitive @p113(1) {
    }
    yasps.primitive @p114(1) {
    }
    yasps.primitive @p115(1) {
    }
    yasps.primitive @p116(1) {
    }
    yasps.primitive @p117(1) {
    }
    yasps.primitive @p118(1) {
    }
    yasps.primitive @p119(1) {
    }
    yasps.primitive @p120(1) {
    }
    yasps.primitive @p121(1) {
    }
    yasps.primitive @p122(1) {
    }
    yasps.primitive @p123(1) {
    }
    yasps.primitive @p124(1) {
    }
    yasps.primitive @p125(1) {
    }
    yasps.primitive @p126(1) {
    }
    yasps.primitive @p127(1) {
    }
    yasps.primitive @p128(1) {
    }
    yasps.primitive @p129(1) {
    }
    yasps.primitive @p130(1) {
    }
    yasps.primitive @p131(1) {
    }
    yasps.primitive @p132(1) {
    }
    yasps.primitive @p133(1) {
    }
    yasps.primitive @p134(1) {
    }
    yasps.primitive @p135(1) {
    }
    yasps.primitive @p136(1) {
    }
    yasps.primitive @p137(1) {
    }
    yasps.primitive @p138(1) {
    }
    yasps.primitive @p139(1) {
    }
    yasps.primitive @p140(1) {
    }
    yasps.primitive @p141(1) {
    }
    yasps.primitive @p142(1) {
    }
    yasps.primitive @p143(1) {
    }
    yasps.primitive @p144(1) {
    }
    yasps.primitive @p145(1) {
    }
    yasps.primitive @p146(1) {
    }
    yasps.primitive @p147(1) {
    }
    yasps.primitive @p148(1) {
    }
    yasps.primitive @p149(1) {
    }
    yasps.primitive @p150(1) {
    }
    yasps.primitive @p151(1) {
    }
    yasps.primitive @p152(1) {
    }
    yasps.primitive @p153(1) {
    }
    yasps.primitive @p154(1) {
    }
    yasps.primitive @p155(1) {
    }
    yasps.primitive @p156(1) {
    }
    yasps.primitive @p157(1) {
    }
    yasps.primitive @p158(1) {
    }
    yasps.primitive @p159(1) {
    }
    yasps.primitive @p160(1) {
    }
    yasps.primitive @p161(1) {
    }
    yasps.primitive @p162(1) {
    }
    yasps.primitive @p163(1) {
    }
    yasps.primitive @p164(1) {
    }
    yasps.primitive @p165(1) {
    }
    yasps.primitive @p166(1) {
    }
    yasps.primitive @p167(1) {
    }
    yasps.primitive @p168(1) {
    }
    yasps.primitive @p169(1) {
    }
    yasps.primitive @p170(1) {
    }
    yasps.primitive @p171(1) {
    }
    yasps.primitive @p172(1) {
    }
    yasps.primitive @p173(1) {
    }
    yasps.primitive @p174(1) {
    }
    yasps.primitive @p175(1) {
    }
    yasps.primitive @p176(1) {
    }
    yasps.primitive @p177(1) {
    }
    yasps.primitive @p178(1) {
    }
    yasps.primitive @p179(1) {
    }
    yasps.primitive @p180(1) {
    }
    yasps.primitive @p181(1) {
    }
    yasps.primitive @p182(1) {
    }
    yasps.primitive @p183(1) {
    }
    yasps.primitive @p184(1) {
    }
    yasps.primitive @p185(1) {
    }
    yasps.primitive @p186(1) {
    }
    yasps.primitive @p187(1) {
    }
    yasps.primitive @p188(1) {
    }
    yasps.primitive @p189(1) {
    }
    yasps.primitive @p190(1) {
    }
    yasps.primitive @p191(1) {
    }
    yasps.primitive @p192(1) {
    }
    yasps.primitive @p193(1) {
    }
    yasps.primitive @p194(1) {
    }
    yasps.primitive @p195(1) {
    }
    yasps.primitive @p196(1) {
    }
    yasps.primitive @p197(1) {
    }
    yasps.primitive @p198(1) {
    }
    yasps.primitive @p199(1) {
    }
    yasps.primitive @p200(1) {
    }
    yasps.primitive @p201(1) {
    }
    yasps.primitive @p202(1) {
    }
    yasps.primitive @p203(1) {
    }
    yasps.primitive @p204(1) {
    }
    yasps.primitive @p205(1) {
    }
    yasps.primitive @p206(1) {
    }
    yasps.primitive @p207(1) {
    }
    yasps.primitive @p208(1) {
    }
    yasps.primitive @p209(1) {
    }
    yasps.primitive @p210(1) {
    }
    yasps.primitive @p211(1) {
    }
    yasps.primitive @p212(1) {
    }
    yasps.primitive @p213(1) {
    }
    yasps.primitive @p214(1) {
    }
    yasps.primitive @p215(1) {
    }
    yasps.primitive @p216(1) {
    }
    yasps.primitive @p217(1) {
    }
    yasps.primitive @p218(1) {
    }
    yasps.primitive @p219(1) {
    }
    yasps.primitive @p220(1) {
    }
    yasps.primitive @p221(1) {
    }
    yasps.primitive @p222(1) {
    }
    yasps.primitive @p223(1) {
    }
    yasps.primitive @p224(1) {
    }
    yasps.primitive @p225(1) {
    }
    yasps.primitive @p226(1) {
    }
    yasps.primitive @p227(1) {
    }
    yasps.primitive @p228(1) {
    }
    yasps.primitive @p229(1) {
    }
    yasps.primitive @p230(1) {
    }
    yasps.primitive @p231(1) {
    }
    yasps.primitive @p232(1) {
    }
    yasps.primitive @p233(1) {
    }
    yasps.primitive @p234(1) {
    }
    yasps.primitive @p235(1) {
    }
    yasps.primitive @p236(1) {
    }
    yasps.primitive @p237(1) {
    }
    yasps.primitive @p238(1) {
    }
    yasps.primitive @p239(1) {
    }
    yasps.primitive @p240(1) {
    }
    yasps.primitive @p241(1) {
    }
    yasps.primitive @p242(1) {
    }
    yasps.primitive @p243(1) {
    }
    yasps.primitive @p244(1) {
    }
    yasps.primitive @p245(1) {
    }
    yasps.primitive @p246(1) {
    }
    yasps.primitive @p247(1) {
    }
    yasps.primitive @p248(1) {
    }
    yasps.primitive @p249(1) {
    }
    yasps.primitive @p250(1) {
    }
    yasps.primitive @p251(1) {
    }
    yasps.primitive @p252(1) {
    }
    yasps.primitive @p253(1) {
    }
    yasps.primitive @p254(1) {
    }
    yasps.primitive @p255(1) {
    }
    yasps.primitive @p256(1) {
    }
    // expected-error @+1 {{primitive union @m::@u has 257 members; a union has at most 256}}
    yasps.primitive_union @u [@m::@p0, @m::@p1, @m::@p2, @m::@p3, @m::@p4, @m::@p5, @m::@p6, @m::@p7, @m::@p8, @m::@p9, @m::@p10, @m::@p11, @m::@p12, @m::@p13, @m::@p14, @m::@p15, @m::@p16, @m::@p17, @m::@p18, @m::@p19, @m::@p20, @m::@p21, @m::@p22, @m::@p23, @m::@p24, @m::@p25, @m::@p26, @m::@p27, @m::@p28, @m::@p29, @m::@p30, @m::@p31, @m::@p32, @m::@p33, @m::@p34, @m::@p35, @m::@p36, @m::@p37, @m::@p38, @m::@p39, @m::@p40, @m::@p41, @m::@p42, @m::@p43, @m::@p44, @m::@p45, @m::@p46, @m::@p47, @m::@p48, @m::@p49, @m::@p50, @m::@p51, @m::@p52, @m::@p53, @m::@p54, @m::@p55, @m::@p56, @m::@p57, @m::@p58, @m::@p59, @m::@p60, @m::@p61, @m::@p62, @m::@p63, @m::@p64, @m::@p65, @m::@p66, @m::@p67, @m::@p68, @m::@p69, @m::@p70, @m::@p71, @m::@p72, @m::@p73, @m::@p74, @m::@p75, @m::@p76, @m::@p77, @m::@p78, @m::@p79, @m::@p80, @m::@p81, @m::@p82, @m::@p83, @m::@p84, @m::@p85, @m::@p86, @m::@p87, @m::@p88, @m::@p89, @m::@p90, @m::@p91, @m::@p92, @m::@p93, @m::@p94, @m::@p95, @m::@p96, @m::@p97, @m::@p98, @m::@p99, @m::@p100, @m::@p101, @m::@p102, @m::@p103, @m::@p104, @m::@p105, @m::@p106, @m::@p107, @m::@p108, @m::@p109, @m::@p110, @m::@p111, @m::@p112, @m::@p113, @m::@p114, @m::@p115, @m::@p116, @m::@p117, @m::@p118, @m::@p119, @m::@p120, @m::@p121, @m::@p122, @m::@p123, @m::@p124, @m::@p125, @m::@p126, @m::@p127, @m::@p128, @m::@p129, @m::@p130, @m::@p131, @m::@p132, @m::@p133, @m::@p134, @m::@p135, @m::@p136, @m::@p137, @m::@p138, @m::@p139, @m::@p140, @m::@p141, @m::@p142, @m::@p143, @m::@p144, @m::@p145, @m::@p146, @m::@p147, @m::@p148, @m::@p149, @m::@p150, @m::@p151, @m::@p152, @m::@p153, @m::@p154, @m::@p155, @m::@p156, @m::@p157, @m::@p158, @m::@p159, @m::@p160, @m::@p161, @m::@p162, @m::@p163, @m::@p164, @m::@p165, @m::@p166, @m::@p167, @m::@p168, @m::@p169, @m::@p170, @m::@p171, @m::@p172, @m::@p173, @m::@p174, @m::@p175, @m::@p176, @m::@p177, @m::@p178, @m::@p179, @m::@p180, @m::@p181, @m::@p182, @m::@p183, @m::@p184, @m::@p185, @m::@p186, @m::@p187, @m::@p188, @m::@p189, @m::@p190, @m::@p191, @m::@p192, @m::@p193, @m::@p194, @m::@p195, @m::@p196, @m::@p197, @m::@p198, @m::@p199, @m::@p200, @m::@p201, @m::@p202, @m::@p203, @m::@p204, @m::@p205, @m::@p206, @m::@p207, @m::@p208, @m::@p209, @m::@p210, @m::@p211, @m::@p212, @m::@p213, @m::@p214, @m::@p215, @m::@p216, @m::@p217, @m::@p218, @m::@p219, @m::@p220, @m::@p221, @m::@p222, @m::@p223, @m::@p224, @m::@p225, @m::@p226, @m::@p227, @m::@p228, @m::@p229, @m::@p230, @m::@p231, @m::@p232, @m::@p233, @m::@p234, @m::@p235, @m::@p236, @m::@p237, @m::@p238, @m::@p239, @m::@p240, @m::@p241, @m::@p242, @m::@p243, @m::@p244, @m::@p245, @m::@p246, @m::@p247, @m::@p248, @m::@p249, @m::@p250, @m::@p251, @m::@p252, @m::@p253, @m::@p254, @m::@p255, @m::@p256] {
    }
  }
}

// -----

// Connectivity: an arity past what a JOIN through it could gather.
yasps.scene @s {
  yasps.mesh @m {
    yasps.primitive @p(1) {
      // expected-error @+1 {{'arity' failed to satisfy constraint}}
      yasps.connectivity @c -> @m::@p arity 16385
    }
  }
}
