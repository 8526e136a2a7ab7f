//===- SurfaceMesh.h - the primitives that can touch ------------*- C++ -*-===//
//
// The surface a contact scene's narrow phase and CCD work on: vertices,
// edges and triangles (the edges of the triangles among the edges), the
// edge of each triangle side, and each edge's squared rest length, which
// fixes IPC's edge-edge mollifier threshold.
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

private:
  int64_t numVertices_;
  std::vector<std::array<int32_t, 2>> edges_;
  std::vector<std::array<int32_t, 3>> faces_;
  std::vector<std::array<int32_t, 3>> faceEdges_;
  std::vector<double> restLength2_;
};

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_CONTACT_SURFACEMESH_H
