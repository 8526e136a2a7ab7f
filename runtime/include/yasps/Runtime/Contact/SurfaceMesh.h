//===- SurfaceMesh.h - the primitives that can touch ------------*- C++ -*-===//
//
// The surface a contact scene's narrow phase and CCD work on: vertices,
// edges and triangles (the edges of the triangles among the edges), the
// edge of each triangle side, and each edge's squared rest length, which
// fixes IPC's edge-edge mollifier threshold. As in ipctk, a vertex on no
// edge is a codimensional point and an edge on no face a codimensional
// edge (a tet mesh's inner vertices are such points): they meet each other
// through vertex-vertex and edge-vertex pairs, and the surface through the
// face-vertex and edge-edge pairs every vertex and edge takes part in.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_CONTACT_SURFACEMESH_H
#define YASPS_RUNTIME_CONTACT_SURFACEMESH_H

#include "yasps/Runtime/Contact/Distance.h"

#include <array>
#include <cstdint>
#include <vector>

namespace yasps::runtime::contact {

/// Positions of a mesh's vertices: row-major (N, 3) doubles, read in place.
struct Positions {
  const double *data = nullptr;
  int64_t count = 0;

  Vec3 operator[](int64_t v) const {
    return {data[3 * v], data[3 * v + 1], data[3 * v + 2]};
  }
};

/// Throws std::invalid_argument naming `what` unless every coordinate of
/// `v` is finite: a NaN or infinite position has no box, distance or time
/// of impact, and would otherwise be skipped without a word.
void checkFinite(Positions v, const char *what);

class SurfaceMesh {
public:
  /// `edges` (E pairs) must contain every side of every face (F triples);
  /// `rest` gives the rest positions of the `numVertices` vertices. Throws
  /// std::invalid_argument on an index out of range or a face side that is
  /// not an edge.
  SurfaceMesh(int64_t numVertices, std::vector<std::array<int32_t, 2>> edges,
              std::vector<std::array<int32_t, 3>> faces, Positions rest);

  int64_t numVertices() const { return numVertices_; }
  const std::vector<std::array<int32_t, 2>> &edges() const { return edges_; }
  const std::vector<std::array<int32_t, 3>> &faces() const { return faces_; }
  /// The edge of side k (corners k and k + 1 mod 3) of each face.
  const std::vector<std::array<int32_t, 3>> &faceEdges() const {
    return faceEdges_;
  }
  double restLength2(int32_t edge) const { return restLength2_[edge]; }
  /// The vertices on no edge, and the edges on no face, in order.
  const std::vector<int32_t> &codimVertices() const { return codimVertices_; }
  const std::vector<int32_t> &codimEdges() const { return codimEdges_; }

private:
  int64_t numVertices_;
  std::vector<std::array<int32_t, 2>> edges_;
  std::vector<std::array<int32_t, 3>> faces_;
  std::vector<std::array<int32_t, 3>> faceEdges_;
  std::vector<double> restLength2_;
  std::vector<int32_t> codimVertices_;
  std::vector<int32_t> codimEdges_;
};

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_CONTACT_SURFACEMESH_H
