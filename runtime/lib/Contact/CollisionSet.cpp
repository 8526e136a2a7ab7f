//===- CollisionSet.cpp - IPC's collision set as pair arrays --------------===//

#include "yasps/Runtime/Contact/CollisionSet.h"

#include "Blocks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

namespace yasps::runtime::contact {

namespace {

uint64_t pairKey(int64_t a, int64_t b) {
  return (static_cast<uint64_t>(a) << 32) | static_cast<uint64_t>(b);
}

/// One active pair as a candidate reduces to: its kind, its vertices, its
/// mollifier threshold, and for point-point and point-edge pairs the key
/// that identifies repeats of it (the pair met through other candidates).
struct Record {
  PairKind kind;
  std::array<int64_t, 4> vertices;
  double epsX;
  uint64_t key;
};

/// The records of a block of candidates, and their smallest squared
/// distance.
struct BlockRecords {
  std::vector<Record> records;
  double minDistance2 = std::numeric_limits<double>::infinity();
};

class Recorder {
public:
  Recorder(const SurfaceMesh &mesh, BlockRecords &out)
      : mesh_(mesh), out_(out) {}

  void distance(double d2) {
    out_.minDistance2 = std::min(out_.minDistance2, d2);
  }

  void pointPoint(int32_t p, int32_t q) {
    out_.records.push_back({PairKind::PointPoint,
                            {p, q, -1, -1},
                            1.0,
                            pairKey(std::min(p, q), std::max(p, q))});
  }

  void pointEdge(int32_t p, int32_t edge) {
    const auto &ends = mesh_.edges()[edge];
    out_.records.push_back({PairKind::PointEdge,
                            {p, ends[0], ends[1], -1},
                            1.0,
                            pairKey(edge, p)});
  }

  void pointTriangle(int32_t p, const std::array<int32_t, 3> &face) {
    out_.records.push_back(
        {PairKind::PointTriangle, {p, face[0], face[1], face[2]}, 1.0, 0});
  }

  void edgeEdge(PairKind kind, std::array<int32_t, 4> v, double epsX) {
    out_.records.push_back({kind, {v[0], v[1], v[2], v[3]}, epsX, 0});
  }

private:
  const SurfaceMesh &mesh_;
  BlockRecords &out_;
};

/// Writes records into the set in order, merging repeated point-point and
/// point-edge pairs into the first, whose weight counts them.
class Merger {
public:
  Merger() { set_.minDistance2 = std::numeric_limits<double>::infinity(); }

  void add(const BlockRecords &block) {
    set_.minDistance2 = std::min(set_.minDistance2, block.minDistance2);
    for (const Record &record : block.records) {
      PairList &list = set_.pairs[static_cast<int>(record.kind)];
      if (record.kind == PairKind::PointPoint ||
          record.kind == PairKind::PointEdge) {
        auto &seen =
            record.kind == PairKind::PointPoint ? pointPoints_ : pointEdges_;
        auto [found, inserted] = seen.emplace(record.key, list.size());
        if (!inserted) {
          list.weight[found->second] += 1.0;
          continue;
        }
      }
      int arity = kPairArity[static_cast<int>(record.kind)];
      list.vertices.insert(list.vertices.end(), record.vertices.begin(),
                           record.vertices.begin() + arity);
      list.epsX.push_back(record.epsX);
      list.weight.push_back(1.0);
    }
  }

  CollisionSet take() { return std::move(set_); }

private:
  CollisionSet set_;
  std::unordered_map<uint64_t, size_t> pointPoints_, pointEdges_;
};

void addEdgeEdge(Recorder &out, const SurfaceMesh &mesh, Positions v,
                 double dhat2, int32_t ea, int32_t eb) {
  auto [a0, a1] = mesh.edges()[ea];
  auto [b0, b1] = mesh.edges()[eb];
  Vec3 pa0 = v[a0], pa1 = v[a1], pb0 = v[b0], pb1 = v[b1];
  EdgeEdgeType type = edgeEdgeType(pa0, pa1, pb0, pb1);
  double d2 = edgeEdgeDistance2(pa0, pa1, pb0, pb1, type);
  if (!(d2 < dhat2))
    return;
  out.distance(d2);
  double epsX =
      edgeEdgeMollifierThreshold(mesh.restLength2(ea), mesh.restLength2(eb));
  if (squaredNorm(cross(pa1 - pa0, pb1 - pb0)) < epsX) {
    // Nearly parallel: the mollifier must act, so the pair stays an
    // edge-edge pair of its type, closest ends first.
    switch (type) {
    case EdgeEdgeType::AB:
      return out.edgeEdge(PairKind::EdgeEdge, {a0, a1, b0, b1}, epsX);
    case EdgeEdgeType::A0B0:
      return out.edgeEdge(PairKind::EdgeEdgeCorners, {a0, a1, b0, b1}, epsX);
    case EdgeEdgeType::A0B1:
      return out.edgeEdge(PairKind::EdgeEdgeCorners, {a0, a1, b1, b0}, epsX);
    case EdgeEdgeType::A1B0:
      return out.edgeEdge(PairKind::EdgeEdgeCorners, {a1, a0, b0, b1}, epsX);
    case EdgeEdgeType::A1B1:
      return out.edgeEdge(PairKind::EdgeEdgeCorners, {a1, a0, b1, b0}, epsX);
    case EdgeEdgeType::A0B:
      return out.edgeEdge(PairKind::EdgeEdgePoint, {a0, a1, b0, b1}, epsX);
    case EdgeEdgeType::A1B:
      return out.edgeEdge(PairKind::EdgeEdgePoint, {a1, a0, b0, b1}, epsX);
    case EdgeEdgeType::AB0:
      return out.edgeEdge(PairKind::EdgeEdgePoint, {b0, b1, a0, a1}, epsX);
    case EdgeEdgeType::AB1:
      return out.edgeEdge(PairKind::EdgeEdgePoint, {b1, b0, a0, a1}, epsX);
    }
  }
  switch (type) {
  case EdgeEdgeType::AB:
    return out.edgeEdge(PairKind::EdgeEdge, {a0, a1, b0, b1}, epsX);
  case EdgeEdgeType::A0B0:
    return out.pointPoint(a0, b0);
  case EdgeEdgeType::A0B1:
    return out.pointPoint(a0, b1);
  case EdgeEdgeType::A1B0:
    return out.pointPoint(a1, b0);
  case EdgeEdgeType::A1B1:
    return out.pointPoint(a1, b1);
  case EdgeEdgeType::A0B:
    return out.pointEdge(a0, eb);
  case EdgeEdgeType::A1B:
    return out.pointEdge(a1, eb);
  case EdgeEdgeType::AB0:
    return out.pointEdge(b0, ea);
  case EdgeEdgeType::AB1:
    return out.pointEdge(b1, ea);
  }
}

void addFaceVertex(Recorder &out, const SurfaceMesh &mesh, Positions v,
                   double dhat2, int32_t f, int32_t p) {
  const auto &face = mesh.faces()[f];
  Vec3 point = v[p], t0 = v[face[0]], t1 = v[face[1]], t2 = v[face[2]];
  PointTriangleType type = pointTriangleType(point, t0, t1, t2);
  double d2 = pointTriangleDistance2(point, t0, t1, t2, type);
  if (!(d2 < dhat2))
    return;
  out.distance(d2);
  const auto &sides = mesh.faceEdges()[f];
  switch (type) {
  case PointTriangleType::Corner0:
  case PointTriangleType::Corner1:
  case PointTriangleType::Corner2:
    return out.pointPoint(p, face[static_cast<int>(type)]);
  case PointTriangleType::Edge0:
  case PointTriangleType::Edge1:
  case PointTriangleType::Edge2:
    return out.pointEdge(p, sides[static_cast<int>(type) -
                                  static_cast<int>(PointTriangleType::Edge0)]);
  case PointTriangleType::Face:
    return out.pointTriangle(p, face);
  }
}

void addVertexVertex(Recorder &out, Positions v, double dhat2, int32_t a,
                     int32_t b) {
  double d2 = squaredNorm(v[a] - v[b]);
  if (!(d2 < dhat2))
    return;
  out.distance(d2);
  out.pointPoint(a, b);
}

void addEdgeVertex(Recorder &out, const SurfaceMesh &mesh, Positions v,
                   double dhat2, int32_t e, int32_t p) {
  const auto &ends = mesh.edges()[e];
  Vec3 point = v[p], e0 = v[ends[0]], e1 = v[ends[1]];
  PointEdgeType type = pointEdgeType(point, e0, e1);
  double d2 = pointEdgeDistance2(point, e0, e1, type);
  if (!(d2 < dhat2))
    return;
  out.distance(d2);
  switch (type) {
  case PointEdgeType::End0:
    return out.pointPoint(p, ends[0]);
  case PointEdgeType::End1:
    return out.pointPoint(p, ends[1]);
  case PointEdgeType::Inside:
    return out.pointEdge(p, e);
  }
}

} // namespace

CollisionSet buildCollisionSet(const SurfaceMesh &mesh,
                               const Candidates &candidates, Positions v,
                               double dhat, ThreadPool *pool) {
  checkFinite(v, "buildCollisionSet");
  checkCandidates(mesh, candidates, "buildCollisionSet");
  if (!(dhat > 0.0) || !std::isfinite(dhat))
    throw std::invalid_argument(
        "buildCollisionSet: dhat must be a finite distance > 0, got " +
        std::to_string(dhat));
  const double dhat2 = dhat * dhat;
  // ipctk's order: vertex-vertex, edge-vertex, edge-edge, face-vertex.
  const int64_t numVertexVertex =
      static_cast<int64_t>(candidates.vertexVertex.size());
  const int64_t numEdgeVertex =
      numVertexVertex + static_cast<int64_t>(candidates.edgeVertex.size());
  const int64_t numEdgeEdge =
      numEdgeVertex + static_cast<int64_t>(candidates.edgeEdge.size());
  const int64_t count =
      numEdgeEdge + static_cast<int64_t>(candidates.faceVertex.size());
  int64_t blocks = blockCount(pool, count, 2048);
  std::vector<BlockRecords> found(blocks);
  forBlocks(pool, count, blocks, [&](int64_t b, int64_t begin, int64_t end) {
    Recorder out(mesh, found[b]);
    for (int64_t i = begin; i < end; ++i) {
      if (i < numVertexVertex) {
        const auto &[a, b] = candidates.vertexVertex[i];
        addVertexVertex(out, v, dhat2, a, b);
      } else if (i < numEdgeVertex) {
        const auto &[e, p] = candidates.edgeVertex[i - numVertexVertex];
        addEdgeVertex(out, mesh, v, dhat2, e, p);
      } else if (i < numEdgeEdge) {
        const auto &[ea, eb] = candidates.edgeEdge[i - numEdgeVertex];
        addEdgeEdge(out, mesh, v, dhat2, ea, eb);
      } else {
        const auto &[f, p] = candidates.faceVertex[i - numEdgeEdge];
        addFaceVertex(out, mesh, v, dhat2, f, p);
      }
    }
  });
  Merger merged;
  for (const BlockRecords &block : found)
    merged.add(block);
  return merged.take();
}

} // namespace yasps::runtime::contact
