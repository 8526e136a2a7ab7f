//===- CollisionSet.h - IPC's collision set as pair arrays ------*- C++ -*-===//
//
// The narrow phase: the candidates closer than dhat, each classified by its
// closest features and recorded as a pair of one of six kinds (the dynamic
// pair primitives of yasps.contact, in the order of its PAIR_TYPES), with
// the vertices in the order that kind's distance reads them. The rules are
// IPC's collision set without area weighting, as ipctk builds it:
//   - a face-vertex pair is a point-triangle pair where the point projects
//     inside the face, else the point-edge or point-point pair it reduces
//     to;
//   - an edge-edge pair whose squared cross product is below the mollifier
//     threshold stays an edge-edge pair of its closest-feature type (the
//     mollifier must act on it); otherwise it reduces like the above;
//   - point-edge and point-point pairs met through several candidates are
//     one pair whose weight counts them.
// ipctk stays the reference: tests compare these sets with its own.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_CONTACT_COLLISIONSET_H
#define YASPS_RUNTIME_CONTACT_COLLISIONSET_H

#include "yasps/Runtime/Contact/BroadPhase.h"

#include <array>
#include <cstdint>
#include <vector>

namespace yasps::runtime::contact {

/// The pair kinds, in the order of yasps.contact.PAIR_TYPES.
enum class PairKind : uint8_t {
  PointPoint,     ///< "vv": p, q
  PointEdge,      ///< "ev": p, e0, e1
  PointTriangle,  ///< "fv": p, t0, t1, t2
  EdgeEdge,       ///< "ee": a0, a1, b0, b1 (closest points inside both)
  EdgeEdgePoint,  ///< "ee_ev": closest end of one edge first, then the other
  EdgeEdgeCorners ///< "ee_vv": each edge with its closest end first
};
constexpr int kNumPairKinds = 6;
constexpr std::array<int, kNumPairKinds> kPairArity = {2, 3, 4, 4, 4, 4};

/// The pairs of one kind: `arity` vertices each, the mollifier threshold
/// eps_x (1 where unused) and the multiplicity weight.
struct PairList {
  std::vector<int64_t> vertices;
  std::vector<double> epsX;
  std::vector<double> weight;

  size_t size() const { return weight.size(); }
};

struct CollisionSet {
  std::array<PairList, kNumPairKinds> pairs;
  /// The smallest squared distance among the pairs (inf if there are none).
  double minDistance2;
};

/// The collision set at positions `v` among `candidates` for barriers of
/// reach `dhat` (a pair is in it if its squared distance is below dhat^2),
/// the same whatever `pool` (nullptr: this thread alone) classifies the
/// candidates.
CollisionSet buildCollisionSet(const SurfaceMesh &mesh,
                               const Candidates &candidates, Positions v,
                               double dhat, ThreadPool *pool = nullptr);

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_CONTACT_COLLISIONSET_H
