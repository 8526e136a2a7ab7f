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
