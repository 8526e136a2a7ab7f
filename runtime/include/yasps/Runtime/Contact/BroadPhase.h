//===- BroadPhase.h - pairs whose swept boxes overlap -----------*- C++ -*-===//
//
// The broad phase of a Newton step: every face-vertex and edge-edge pair
// whose boxes, swept over the straight motion V0 -> V1 and grown by an
// inflation radius, overlap. With the radius half the barrier's reach,
// these candidates hold every pair that comes within that reach anywhere on
// the path, so the step's CCD and the collision set of every line-search
// candidate are narrow phases over them (IPC's own solver does the same).
// In 3D these two kinds cover every closest-feature pair of a surface: a
// vertex-vertex or edge-vertex contact is the end of a face-vertex or
// edge-edge one. Codimensional points and edges (SurfaceMesh) add, as in
// ipctk, vertex-vertex pairs among the points and edge-vertex pairs between
// the edges and the points.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_CONTACT_BROADPHASE_H
#define YASPS_RUNTIME_CONTACT_BROADPHASE_H

#include "yasps/Runtime/Contact/SurfaceMesh.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <array>
#include <cstdint>
#include <vector>

namespace yasps::runtime::contact {

struct Candidates {
  /// (face, vertex), the vertex not a corner of the face.
  std::vector<std::array<int32_t, 2>> faceVertex;
  /// (edge a, edge b), a < b, sharing no vertex.
  std::vector<std::array<int32_t, 2>> edgeEdge;
  /// (vertex a, vertex b), a < b, both codimensional points.
  std::vector<std::array<int32_t, 2>> vertexVertex;
  /// (edge, vertex), a codimensional edge and a codimensional point.
  std::vector<std::array<int32_t, 2>> edgeVertex;

  size_t size() const {
    return faceVertex.size() + edgeEdge.size() + vertexVertex.size() +
           edgeVertex.size();
  }
};

/// Throws std::invalid_argument (naming `who`) unless every index of
/// `candidates` is one of `mesh`'s faces, edges or vertices: candidates
/// found on another mesh would read outside this one's arrays.
void checkCandidates(const SurfaceMesh &mesh, const Candidates &candidates,
                     const char *who);

/// The candidates of the motion V0 -> V1 (V1 may be V0: a broad phase at
/// rest) whose boxes grown by `inflation` overlap, found cell by cell in a
/// uniform grid of the boxes; the pairs come in a fixed order (by grid
/// cell), whatever `pool` (nullptr: this thread alone) runs the cells.
Candidates sweptCandidates(const SurfaceMesh &mesh, Positions v0, Positions v1,
                           double inflation, ThreadPool *pool = nullptr);

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_CONTACT_BROADPHASE_H
