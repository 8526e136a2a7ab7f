//===- ContactTest.cpp - distances, broad phase and CCD of contact --------===//
//
// Each checked against a plainer formulation: distances against the
// minimum over the features' clamped projections, the grid broad phase
// against every pair's boxes, the collision set against the distances, the
// additive CCD against the distances along the step. (The Python tests
// compare the same stages with ipctk.)
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Contact/AdditiveCcd.h"
#include "yasps/Runtime/Contact/CollisionSet.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

using namespace yasps::runtime;
using namespace yasps::runtime::contact;

namespace {

Vec3 randomPoint(std::mt19937 &rng, double scale = 1.0) {
  std::normal_distribution<double> normal(0.0, scale);
  return {normal(rng), normal(rng), normal(rng)};
}

double pointSegment2(Vec3 p, Vec3 a, Vec3 b) {
  Vec3 e = b - a;
  double t = std::clamp(dot(p - a, e) / squaredNorm(e), 0.0, 1.0);
  return squaredNorm(p - (a + t * e));
}

/// The closest point is inside the face (then on the plane) or on a side.
double pointTriangleReference(Vec3 p, Vec3 t0, Vec3 t1, Vec3 t2) {
  Vec3 n = cross(t1 - t0, t2 - t0);
  Vec3 q = p - (dot(p - t0, n) / squaredNorm(n)) * n;
  bool inside = dot(cross(t1 - t0, q - t0), n) >= 0 &&
                dot(cross(t2 - t1, q - t1), n) >= 0 &&
                dot(cross(t0 - t2, q - t2), n) >= 0;
  if (inside)
    return squaredNorm(p - q);
  return std::min({pointSegment2(p, t0, t1), pointSegment2(p, t1, t2),
                   pointSegment2(p, t2, t0)});
}

/// The closest points are inside both edges or an end against an edge.
double edgeEdgeReference(Vec3 a0, Vec3 a1, Vec3 b0, Vec3 b1) {
  double best =
      std::min({pointSegment2(a0, b0, b1), pointSegment2(a1, b0, b1),
                pointSegment2(b0, a0, a1), pointSegment2(b1, a0, a1)});
  Vec3 u = a1 - a0, v = b1 - b0, w = a0 - b0;
  double a = dot(u, u), b = dot(u, v), c = dot(v, v), d = dot(u, w),
         e = dot(v, w), det = a * c - b * b;
  if (det > 1e-12 * a * c) {
    double s = (b * e - c * d) / det, t = (a * e - b * d) / det;
    if (s > 0 && s < 1 && t > 0 && t < 1)
      best = std::min(best, squaredNorm((a0 + s * u) - (b0 + t * v)));
  }
  return best;
}

TEST(ContactDistance, PointTriangleMatchesClampedProjections) {
  std::mt19937 rng(1);
  for (int i = 0; i < 20000; ++i) {
    Vec3 p = randomPoint(rng), t0 = randomPoint(rng), t1 = randomPoint(rng),
         t2 = randomPoint(rng);
    double want = pointTriangleReference(p, t0, t1, t2);
    EXPECT_NEAR(pointTriangleDistance2(p, t0, t1, t2), want, 1e-10 * (1 + want))
        << "sample " << i;
  }
}

TEST(ContactDistance, EdgeEdgeMatchesClampedProjections) {
  std::mt19937 rng(2);
  for (int i = 0; i < 20000; ++i) {
    Vec3 a0 = randomPoint(rng), a1 = randomPoint(rng), b0 = randomPoint(rng),
         b1 = randomPoint(rng);
    double want = edgeEdgeReference(a0, a1, b0, b1);
    EXPECT_NEAR(edgeEdgeDistance2(a0, a1, b0, b1), want, 1e-10 * (1 + want))
        << "sample " << i;
  }
}

TEST(ContactDistance, ParallelEdgesTakeTheirCommonDistance) {
  // b lies along a's line, 0.1 above it, over several overlaps.
  Vec3 a0{0, 0, 0}, a1{1, 0, 0};
  for (double start : {-2.0, -0.5, 0.3, 0.8, 1.5}) {
    for (double length : {0.2, 1.0, 3.0}) {
      Vec3 b0{start, 0.1, 0}, b1{start + length, 0.1, 0};
      double want = edgeEdgeReference(a0, a1, b0, b1);
      EXPECT_NEAR(edgeEdgeDistance2(a0, a1, b0, b1), want, 1e-14)
          << start << " " << length;
      EXPECT_NEAR(edgeEdgeDistance2(a0, a1, b1, b0), want, 1e-14)
          << start << " " << length;
    }
  }
}

/// A sheet of n x n vertices in the plane z = 0 and a copy turned and
/// lifted by `gap`, both jittered.
struct TwoSheets {
  std::vector<double> positions;
  std::vector<std::array<int32_t, 2>> edges;
  std::vector<std::array<int32_t, 3>> faces;

  TwoSheets(int n, double gap, double jitter, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, jitter);
    for (int sheet = 0; sheet < 2; ++sheet) {
      int32_t base = sheet * n * n;
      double c = std::cos(0.4 * sheet), s = std::sin(0.4 * sheet);
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          double x = double(i) / (n - 1), y = double(j) / (n - 1);
          positions.insert(positions.end(), {c * x - s * y + noise(rng),
                                             s * x + c * y + noise(rng),
                                             sheet * gap + noise(rng)});
        }
      for (int i = 0; i + 1 < n; ++i)
        for (int j = 0; j + 1 < n; ++j) {
          int32_t a = base + i * n + j, b = a + n, d = a + 1, e = b + 1;
          faces.push_back({a, b, e});
          faces.push_back({a, e, d});
          edges.push_back({a, b});
          edges.push_back({a, d});
          edges.push_back({a, e});
          if (i + 2 == n)
            edges.push_back({b, e});
          if (j + 2 == n)
            edges.push_back({d, e});
        }
    }
  }

  Positions at() const {
    return {positions.data(), static_cast<int64_t>(positions.size() / 3)};
  }
  SurfaceMesh mesh() const {
    return SurfaceMesh(at().count, edges, faces, at());
  }
};

TEST(ContactBroadPhase, FindsEveryOverlappingPairOnce) {
  // Enough faces and edges for several blocks on the pool.
  TwoSheets sheets(13, 0.05, 0.02, 3);
  ASSERT_GT(sheets.faces.size(), 2 * 256u);
  SurfaceMesh mesh = sheets.mesh();
  std::vector<double> moved = sheets.positions;
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.03);
  for (double &x : moved)
    x += noise(rng);
  Positions v0 = sheets.at(), v1{moved.data(), v0.count};
  const double r = 0.01;
  auto box = [&](std::initializer_list<int32_t> ids, int k, bool upper) {
    double out = upper ? -1e300 : 1e300;
    for (int32_t v : ids)
      for (Positions p : {v0, v1})
        out = upper ? std::max(out, p[v][k] + r) : std::min(out, p[v][k] - r);
    return out;
  };
  auto overlap = [&](std::initializer_list<int32_t> a,
                     std::initializer_list<int32_t> b) {
    for (int k = 0; k < 3; ++k)
      if (box(a, k, false) > box(b, k, true) ||
          box(b, k, false) > box(a, k, true))
        return false;
    return true;
  };
  std::set<std::array<int32_t, 2>> want, got;
  for (int32_t f = 0; f < int32_t(sheets.faces.size()); ++f) {
    auto t = sheets.faces[f];
    for (int32_t v = 0; v < v0.count; ++v)
      if (v != t[0] && v != t[1] && v != t[2] &&
          overlap({t[0], t[1], t[2]}, {v}))
        want.insert({f, v});
  }
  Candidates serial = sweptCandidates(mesh, v0, v1, r);
  for (ThreadPool *pool :
       {static_cast<ThreadPool *>(nullptr), &defaultThreadPool()}) {
    Candidates c = sweptCandidates(mesh, v0, v1, r, pool);
    // The same pairs in the same order on any pool.
    EXPECT_EQ(c.faceVertex, serial.faceVertex);
    EXPECT_EQ(c.edgeEdge, serial.edgeEdge);
    got = std::set<std::array<int32_t, 2>>(c.faceVertex.begin(),
                                           c.faceVertex.end());
    EXPECT_EQ(got.size(), c.faceVertex.size());
    EXPECT_EQ(got, want);
    std::set<std::array<int32_t, 2>> edgePairs(c.edgeEdge.begin(),
                                               c.edgeEdge.end());
    EXPECT_EQ(edgePairs.size(), c.edgeEdge.size());
    size_t count = 0;
    for (int32_t a = 0; a < int32_t(sheets.edges.size()); ++a)
      for (int32_t b = a + 1; b < int32_t(sheets.edges.size()); ++b) {
        auto ea = sheets.edges[a], eb = sheets.edges[b];
        if (ea[0] == eb[0] || ea[0] == eb[1] || ea[1] == eb[0] ||
            ea[1] == eb[1])
          continue;
        if (overlap({ea[0], ea[1]}, {eb[0], eb[1]})) {
          ++count;
          EXPECT_TRUE(edgePairs.count({a, b})) << a << " " << b;
        }
      }
    EXPECT_EQ(count, c.edgeEdge.size());
  }
}

TEST(ContactBroadPhase, MeshesWithoutFacesOrEdgesHaveTheirPairs) {
  // Points alone (no edge, no face: every vertex a codimensional point),
  // then rods (edges on no face) among them: empty sets of boxes leave
  // their grids empty, and the pairs are brute force's.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> at(0.0, 0.1);
  std::vector<double> positions(3 * 60);
  for (double &x : positions)
    x = at(rng);
  Positions v{positions.data(), 60};
  const double r = 0.01;
  auto near = [&](int32_t a, int32_t b) {
    for (int k = 0; k < 3; ++k)
      if (std::abs(v[a][k] - v[b][k]) > 2 * r)
        return false;
    return true;
  };
  for (bool rods : {false, true}) {
    std::vector<std::array<int32_t, 2>> edges;
    if (rods)
      for (int32_t i = 40; i < 60; i += 2)
        edges.push_back({i, i + 1});
    SurfaceMesh mesh(60, edges, {}, v);
    Candidates c = sweptCandidates(mesh, v, v, r, &defaultThreadPool());
    EXPECT_TRUE(c.faceVertex.empty());
    std::set<std::array<int32_t, 2>> want;
    const int32_t points = rods ? 40 : 60;
    for (int32_t a = 0; a < points; ++a)
      for (int32_t b = a + 1; b < points; ++b)
        if (near(a, b))
          want.insert({a, b});
    ASSERT_FALSE(want.empty());
    std::set<std::array<int32_t, 2>> got(c.vertexVertex.begin(),
                                         c.vertexVertex.end());
    EXPECT_EQ(got, want);
    EXPECT_EQ(c.vertexVertex.size(), want.size());
    if (rods)
      EXPECT_FALSE(c.edgeVertex.empty());
    else
      EXPECT_TRUE(c.edgeEdge.empty() && c.edgeVertex.empty());
  }
}

TEST(ContactBroadPhase, RefusesNonFinitePositions) {
  TwoSheets sheets(4, 0.05, 0.0, 7);
  SurfaceMesh mesh = sheets.mesh();
  std::vector<double> bad = sheets.positions;
  bad[3 * 5 + 1] = std::nan("");
  Positions good = sheets.at(), broken{bad.data(), good.count};
  Candidates c = sweptCandidates(mesh, good, good, 0.01);
  EXPECT_THROW(sweptCandidates(mesh, good, broken, 0.01),
               std::invalid_argument);
  EXPECT_THROW(buildCollisionSet(mesh, c, broken, 0.01), std::invalid_argument);
  EXPECT_THROW(additiveStepBound(mesh, c, good, broken, 1e-9),
               std::invalid_argument);
  bad[3 * 5 + 1] = INFINITY;
  EXPECT_THROW(candidateMinDistance2(mesh, c, broken), std::invalid_argument);
}

TEST(ContactCollisionSet, HoldsThePairsCloserThanDhatWhateverTheThreads) {
  TwoSheets sheets(20, 0.02, 0.004, 5);
  SurfaceMesh mesh = sheets.mesh();
  Positions v = sheets.at();
  const double dhat = 0.015;
  Candidates c = sweptCandidates(mesh, v, v, 0.5 * dhat);
  ASSERT_GT(c.size(), 2 * 2048u); // several blocks on the pool
  CollisionSet serial = buildCollisionSet(mesh, c, v, dhat);
  CollisionSet parallel =
      buildCollisionSet(mesh, c, v, dhat, &defaultThreadPool());
  double closest = 1e300;
  size_t active = 0;
  for (auto [f, p] : c.faceVertex) {
    auto t = sheets.faces[f];
    double d2 = pointTriangleDistance2(v[p], v[t[0]], v[t[1]], v[t[2]]);
    active += d2 < dhat * dhat;
    closest = std::min(closest, d2);
  }
  for (auto [a, b] : c.edgeEdge) {
    auto ea = sheets.edges[a], eb = sheets.edges[b];
    double d2 = edgeEdgeDistance2(v[ea[0]], v[ea[1]], v[eb[0]], v[eb[1]]);
    active += d2 < dhat * dhat;
    closest = std::min(closest, d2);
  }
  ASSERT_GT(active, 50u);
  // Every active candidate is one pair or one more count of a merged one.
  double weights = 0;
  for (int k = 0; k < kNumPairKinds; ++k) {
    const PairList &list = serial.pairs[k];
    EXPECT_EQ(list.vertices.size(), list.size() * kPairArity[k]);
    for (double w : list.weight)
      weights += w;
    EXPECT_EQ(list.vertices, parallel.pairs[k].vertices);
    EXPECT_EQ(list.weight, parallel.pairs[k].weight);
    EXPECT_EQ(list.epsX, parallel.pairs[k].epsX);
  }
  EXPECT_EQ(weights, double(active));
  EXPECT_EQ(serial.minDistance2, closest);
  EXPECT_EQ(parallel.minDistance2, closest);
}

TEST(ContactCcd, StopsBeforeEveryPairComesCloserThanTheSeparation) {
  TwoSheets sheets(16, 0.01, 0.001, 6);
  SurfaceMesh mesh = sheets.mesh();
  Positions v0 = sheets.at();
  std::vector<double> moved = sheets.positions;
  // The upper sheet falls through the lower one.
  for (size_t i = moved.size() / 2; i < moved.size(); i += 3)
    moved[i + 2] -= 0.05;
  Positions v1{moved.data(), v0.count};
  Candidates c = sweptCandidates(mesh, v0, v1, 0.0);
  ASSERT_GT(c.size(), 2 * 1024u); // several blocks on the pool
  const double separation = 1e-4;
  StepBound serial = additiveStepBound(mesh, c, v0, v1, separation);
  StepBound threaded = additiveStepBound(
      mesh, c, v0, v1, separation, kAdditiveCcdRescaling, &defaultThreadPool());
  double bound = serial.fraction;
  EXPECT_EQ(bound, threaded.fraction);
  // The closest distance at the start comes with the bound.
  EXPECT_EQ(serial.minDistance2, candidateMinDistance2(mesh, c, v0));
  EXPECT_EQ(threaded.minDistance2, serial.minDistance2);
  ASSERT_GT(bound, 0.0);
  ASSERT_LT(bound, 1.0);
  // Along the bounded step every candidate keeps the separation; the
  // closest comes near it (within what the additive CCD leaves: 10% of the
  // starting gap).
  double closestAtBound = 1e300;
  for (int step = 0; step <= 200; ++step) {
    double t = bound * step / 200.0;
    std::vector<double> at(moved.size());
    for (size_t i = 0; i < at.size(); ++i)
      at[i] = sheets.positions[i] + t * (moved[i] - sheets.positions[i]);
    Positions v{at.data(), v0.count};
    double d2 = candidateMinDistance2(mesh, c, v);
    EXPECT_GT(std::sqrt(d2), separation) << "at " << t;
    if (step == 200)
      closestAtBound = std::sqrt(d2);
  }
  EXPECT_LT(closestAtBound, separation + 0.2 * 0.01);
}

} // namespace
