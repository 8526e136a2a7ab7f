//===- AdditiveCcd.cpp - the largest step that keeps surfaces apart -------===//

#include "yasps/Runtime/Contact/AdditiveCcd.h"

#include "Blocks.h"

#include <atomic>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace yasps::runtime::contact {

namespace {

/// A pair's points (two to four) now and their displacements over the
/// whole step, less the mean displacement (a common translation closes no
/// distance).
struct Motion {
  std::array<Vec3, 4> x, dx;

  Motion(Positions v0, Positions v1, std::initializer_list<int32_t> ids) {
    Vec3 mean;
    int k = 0;
    for (int32_t id : ids) {
      x[k] = v0[id];
      dx[k] = v1[id] - x[k];
      mean = mean + (1.0 / ids.size()) * dx[k];
      ++k;
    }
    for (int j = 0; j < k; ++j)
      dx[j] = dx[j] - mean;
  }

  double length(int k) const { return std::sqrt(squaredNorm(dx[k])); }
};

/// Guards a pair whose advance stalls (a gap near round-off): the fraction
/// reached so far is returned, which is conservative.
constexpr long kMaxIterations = 10'000'000L;

/// A pair's time of impact (the fraction of the step, +inf for none
/// before the bound asked for) and its squared distance at the start.
struct Impact {
  double toi, distance2;
};

/// Algorithm 1 of the additive CCD. `maxDisplacement` bounds how fast the
/// distance can close per unit of the step. Returns the fraction at which
/// the pair's distance has closed to the gap, or +inf if it does not
/// before `tmax`, and the distance at the start.
template <typename Distance2>
Impact additiveImpact(Motion motion, double maxDisplacement, double minDistance,
                      double tmax, double rescaling, Distance2 &&distance2) {
  const double inf = std::numeric_limits<double>::infinity();
  const double min2 = minDistance * minDistance;
  const double start2 = distance2(motion.x);
  double d2 = start2;
  if (d2 <= min2)
    return {0.0, start2};
  if (maxDisplacement == 0)
    return {inf, start2};
  double d = std::sqrt(d2), excess = d2 - min2;
  // (d - min) as (d^2 - min^2) / (d + min): no cancellation near min.
  const double gap = (1 - rescaling) * excess / (d + minDistance);
  double toi = 0;
  for (long i = 0; i < kMaxIterations; ++i) {
    double advance = rescaling * excess / ((d + minDistance) * maxDisplacement);
    // The first advance past tmax ends the pair without another distance:
    // the test below needs toi > 0. Most candidates end here.
    if (toi == 0 && advance > tmax)
      return {inf, start2};
    for (int k = 0; k < 4; ++k) // unused points move by zero
      motion.x[k] = motion.x[k] + advance * motion.dx[k];
    d2 = distance2(motion.x);
    d = std::sqrt(d2);
    excess = d2 - min2;
    if (toi > 0 && (excess <= 0 || excess / (d + minDistance) < gap))
      return {toi, start2};
    toi += advance;
    if (toi > tmax)
      return {inf, start2};
  }
  return {toi, start2};
}

Impact vertexVertexImpact(Positions v0, Positions v1, int32_t a, int32_t b,
                          double minDistance, double tmax, double rescaling) {
  Motion motion(v0, v1, {a, b});
  return additiveImpact(
      motion, motion.length(0) + motion.length(1), minDistance, tmax, rescaling,
      [](const std::array<Vec3, 4> &x) { return squaredNorm(x[0] - x[1]); });
}

Impact edgeVertexImpact(const SurfaceMesh &mesh, Positions v0, Positions v1,
                        int32_t e, int32_t p, double minDistance, double tmax,
                        double rescaling) {
  const auto &ends = mesh.edges()[e];
  Motion motion(v0, v1, {p, ends[0], ends[1]});
  double maxDisplacement =
      motion.length(0) + std::max(motion.length(1), motion.length(2));
  return additiveImpact(motion, maxDisplacement, minDistance, tmax, rescaling,
                        [](const std::array<Vec3, 4> &x) {
                          return pointEdgeDistance2(x[0], x[1], x[2]);
                        });
}

Impact faceVertexImpact(const SurfaceMesh &mesh, Positions v0, Positions v1,
                        int32_t f, int32_t p, double minDistance, double tmax,
                        double rescaling) {
  const auto &face = mesh.faces()[f];
  Motion motion(v0, v1, {p, face[0], face[1], face[2]});
  double maxDisplacement =
      motion.length(0) +
      std::max({motion.length(1), motion.length(2), motion.length(3)});
  return additiveImpact(motion, maxDisplacement, minDistance, tmax, rescaling,
                        [](const std::array<Vec3, 4> &x) {
                          return pointTriangleDistance2(x[0], x[1], x[2], x[3]);
                        });
}

Impact edgeEdgeImpact(const SurfaceMesh &mesh, Positions v0, Positions v1,
                      int32_t ea, int32_t eb, double minDistance, double tmax,
                      double rescaling) {
  const auto &a = mesh.edges()[ea], &b = mesh.edges()[eb];
  Motion motion(v0, v1, {a[0], a[1], b[0], b[1]});
  double maxDisplacement = std::max(motion.length(0), motion.length(1)) +
                           std::max(motion.length(2), motion.length(3));
  return additiveImpact(motion, maxDisplacement, minDistance, tmax, rescaling,
                        [](const std::array<Vec3, 4> &x) {
                          return edgeEdgeDistance2(x[0], x[1], x[2], x[3]);
                        });
}

} // namespace

StepBound additiveStepBound(const SurfaceMesh &mesh,
                            const Candidates &candidates, Positions v0,
                            Positions v1, double minDistance, double rescaling,
                            ThreadPool *pool) {
  checkFinite(v0, "additiveStepBound");
  checkFinite(v1, "additiveStepBound");
  checkCandidates(mesh, candidates, "additiveStepBound");
  if (!(minDistance >= 0.0) || !std::isfinite(minDistance))
    throw std::invalid_argument(
        "additiveStepBound: the distance to keep must be finite and >= 0, "
        "got " +
        std::to_string(minDistance));
  // Each pair runs only up to the earliest impact found so far: the
  // minimum is the same in any order, and later pairs stop sooner.
  std::atomic<double> earliest(1.0);
  auto lower = [&](double toi) {
    double now = earliest.load(std::memory_order_relaxed);
    while (toi < now && !earliest.compare_exchange_weak(
                            now, toi, std::memory_order_relaxed)) {
    }
  };
  const int64_t numFaceVertex =
      static_cast<int64_t>(candidates.faceVertex.size());
  const int64_t numEdgeEdge =
      numFaceVertex + static_cast<int64_t>(candidates.edgeEdge.size());
  const int64_t numVertexVertex =
      numEdgeEdge + static_cast<int64_t>(candidates.vertexVertex.size());
  const int64_t count =
      numVertexVertex + static_cast<int64_t>(candidates.edgeVertex.size());
  const int64_t blocks = blockCount(pool, count, 1024);
  // The closest distance per block, then over the blocks: a minimum, the
  // same in any order.
  std::vector<double> closest(static_cast<size_t>(blocks),
                              std::numeric_limits<double>::infinity());
  forBlocks(
      pool, count, blocks, [&](int64_t block, int64_t begin, int64_t end) {
        double least = std::numeric_limits<double>::infinity();
        for (int64_t i = begin; i < end; ++i) {
          double tmax = earliest.load(std::memory_order_relaxed);
          Impact impact;
          if (i < numFaceVertex) {
            const auto &[f, p] = candidates.faceVertex[i];
            impact = faceVertexImpact(mesh, v0, v1, f, p, minDistance, tmax,
                                      rescaling);
          } else if (i < numEdgeEdge) {
            const auto &[ea, eb] = candidates.edgeEdge[i - numFaceVertex];
            impact = edgeEdgeImpact(mesh, v0, v1, ea, eb, minDistance, tmax,
                                    rescaling);
          } else if (i < numVertexVertex) {
            const auto &[a, b] = candidates.vertexVertex[i - numEdgeEdge];
            impact =
                vertexVertexImpact(v0, v1, a, b, minDistance, tmax, rescaling);
          } else {
            const auto &[e, p] = candidates.edgeVertex[i - numVertexVertex];
            impact = edgeVertexImpact(mesh, v0, v1, e, p, minDistance, tmax,
                                      rescaling);
          }
          lower(impact.toi);
          least = std::min(least, impact.distance2);
        }
        closest[static_cast<size_t>(block)] = least;
      });
  return {earliest.load(), *std::min_element(closest.begin(), closest.end())};
}

double candidateMinDistance2(const SurfaceMesh &mesh,
                             const Candidates &candidates, Positions v) {
  checkFinite(v, "candidateMinDistance2");
  checkCandidates(mesh, candidates, "candidateMinDistance2");
  double least = std::numeric_limits<double>::infinity();
  for (const auto &[f, p] : candidates.faceVertex) {
    const auto &face = mesh.faces()[f];
    least = std::min(least, pointTriangleDistance2(v[p], v[face[0]], v[face[1]],
                                                   v[face[2]]));
  }
  for (const auto &[ea, eb] : candidates.edgeEdge) {
    const auto &a = mesh.edges()[ea], &b = mesh.edges()[eb];
    least =
        std::min(least, edgeEdgeDistance2(v[a[0]], v[a[1]], v[b[0]], v[b[1]]));
  }
  for (const auto &[a, b] : candidates.vertexVertex)
    least = std::min(least, squaredNorm(v[a] - v[b]));
  for (const auto &[e, p] : candidates.edgeVertex) {
    const auto &ends = mesh.edges()[e];
    least = std::min(least, pointEdgeDistance2(v[p], v[ends[0]], v[ends[1]]));
  }
  return least;
}

} // namespace yasps::runtime::contact
