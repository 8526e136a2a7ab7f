//===- Distance.h - closest features and squared distances -----*- C++ -*-===//
//
// The geometry of IPC's contact pairs: which features of a point and a
// triangle, or of two edges, are closest (the distance type), and the
// squared distance of each type. A pair's barrier is evaluated on its
// type's distance, so the narrow phase, the CCD and the step's energies must
// classify alike; ipctk's classification (its distance types) is the
// reference the tests compare these with.
//
// Header-only and free of the standard library beyond <cmath>, so that a
// GPU narrow phase can share the bodies (YASPS_HD).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_CONTACT_DISTANCE_H
#define YASPS_RUNTIME_CONTACT_DISTANCE_H

#include "yasps/Runtime/Support/HostDevice.h"

#include <cstdint>

namespace yasps::runtime::contact {

struct Vec3 {
  double x = 0, y = 0, z = 0;

  YASPS_HD double operator[](int axis) const {
    return axis == 0 ? x : (axis == 1 ? y : z);
  }
};

YASPS_HD inline Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
YASPS_HD inline Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
YASPS_HD inline Vec3 operator*(double s, Vec3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
YASPS_HD inline double dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
YASPS_HD inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
YASPS_HD inline double squaredNorm(Vec3 a) { return dot(a, a); }

/// The closest features of a point and an edge (e0, e1).
enum class PointEdgeType : uint8_t { End0, End1, Inside };

/// The closest features of a point and a triangle (t0, t1, t2). Edge k
/// joins corner k and corner k + 1 (mod 3), as ipctk numbers them.
enum class PointTriangleType : uint8_t {
  Corner0,
  Corner1,
  Corner2,
  Edge0,
  Edge1,
  Edge2,
  Face
};

/// The closest features of edges a = (a0, a1) and b = (b0, b1), numbered as
/// ipctk's EdgeEdgeDistanceType: an end point (A0, A1, B0, B1) or the
/// inside of an edge (A, B).
enum class EdgeEdgeType : uint8_t {
  A0B0,
  A0B1,
  A1B0,
  A1B1,
  AB0,
  AB1,
  A0B,
  A1B,
  AB
};

/// Squared distance from p to the line through e0 and e1.
YASPS_HD inline double pointLineDistance2(Vec3 p, Vec3 e0, Vec3 e1) {
  Vec3 e = e1 - e0;
  return squaredNorm(cross(p - e0, e)) / squaredNorm(e);
}

/// Where p projects onto the edge's line: before e0, past e1, or between.
YASPS_HD inline PointEdgeType pointEdgeType(Vec3 p, Vec3 e0, Vec3 e1) {
  Vec3 e = e1 - e0;
  double along = dot(p - e0, e);
  if (along < 0)
    return PointEdgeType::End0;
  return along > squaredNorm(e) ? PointEdgeType::End1 : PointEdgeType::Inside;
}

YASPS_HD inline double pointEdgeDistance2(Vec3 p, Vec3 e0, Vec3 e1,
                                          PointEdgeType type) {
  switch (type) {
  case PointEdgeType::End0:
    return squaredNorm(p - e0);
  case PointEdgeType::End1:
    return squaredNorm(p - e1);
  case PointEdgeType::Inside:
    break;
  }
  return pointLineDistance2(p, e0, e1);
}

YASPS_HD inline double pointEdgeDistance2(Vec3 p, Vec3 e0, Vec3 e1) {
  return pointEdgeDistance2(p, e0, e1, pointEdgeType(p, e0, e1));
}

/// Squared distance from p to the plane of (t0, t1, t2).
YASPS_HD inline double pointPlaneDistance2(Vec3 p, Vec3 t0, Vec3 t1, Vec3 t2) {
  Vec3 n = cross(t1 - t0, t2 - t0);
  double h = dot(p - t0, n);
  return h * h / squaredNorm(n);
}

/// Squared distance between the lines through (a0, a1) and (b0, b1).
YASPS_HD inline double lineLineDistance2(Vec3 a0, Vec3 a1, Vec3 b0, Vec3 b1) {
  Vec3 n = cross(a1 - a0, b1 - b0);
  double h = dot(a0 - b0, n);
  return h * h / squaredNorm(n);
}

/// The region of the triangle's plane that p projects into, by the signs of
/// its barycentric parts (the textbook closest-point-on-triangle tests).
YASPS_HD inline PointTriangleType pointTriangleType(Vec3 p, Vec3 t0, Vec3 t1,
                                                    Vec3 t2) {
  Vec3 ab = t1 - t0, ac = t2 - t0;
  Vec3 ap = p - t0;
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0)
    return PointTriangleType::Corner0;
  Vec3 bp = p - t1;
  double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3)
    return PointTriangleType::Corner1;
  if (d1 * d4 - d3 * d2 <= 0 && d1 >= 0 && d3 <= 0)
    return PointTriangleType::Edge0;
  Vec3 cp = p - t2;
  double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6)
    return PointTriangleType::Corner2;
  if (d5 * d2 - d1 * d6 <= 0 && d2 >= 0 && d6 <= 0)
    return PointTriangleType::Edge2;
  if (d3 * d6 - d5 * d4 <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return PointTriangleType::Edge1;
  return PointTriangleType::Face;
}

YASPS_HD inline double pointTriangleDistance2(Vec3 p, Vec3 t0, Vec3 t1, Vec3 t2,
                                              PointTriangleType type) {
  switch (type) {
  case PointTriangleType::Corner0:
    return squaredNorm(p - t0);
  case PointTriangleType::Corner1:
    return squaredNorm(p - t1);
  case PointTriangleType::Corner2:
    return squaredNorm(p - t2);
  case PointTriangleType::Edge0:
    return pointLineDistance2(p, t0, t1);
  case PointTriangleType::Edge1:
    return pointLineDistance2(p, t1, t2);
  case PointTriangleType::Edge2:
    return pointLineDistance2(p, t2, t0);
  case PointTriangleType::Face:
    break;
  }
  return pointPlaneDistance2(p, t0, t1, t2);
}

YASPS_HD inline double pointTriangleDistance2(Vec3 p, Vec3 t0, Vec3 t1,
                                              Vec3 t2) {
  return pointTriangleDistance2(p, t0, t1, t2,
                                pointTriangleType(p, t0, t1, t2));
}

/// Parallel edges have no unique closest points: the type names features
/// at the common distance. With alpha and beta the parameters of b0 and b1
/// along a, an end of b that projects inside a is closest to a's line;
/// otherwise, where b spans a, an end of a to b's line; otherwise the
/// nearest ends.
YASPS_HD inline EdgeEdgeType parallelEdgeEdgeType(Vec3 a0, Vec3 a1, Vec3 b0,
                                                  Vec3 b1) {
  Vec3 a = a1 - a0;
  double length2 = squaredNorm(a);
  double alpha = dot(b0 - a0, a) / length2, beta = dot(b1 - a0, a) / length2;
  bool betaInside = 0 <= beta && beta <= 1;
  if (alpha < 0) {
    if (betaInside)
      return EdgeEdgeType::AB1;
    return beta <= alpha ? EdgeEdgeType::A0B0
                         : (beta <= 1 ? EdgeEdgeType::A0B1 : EdgeEdgeType::A0B);
  }
  if (alpha > 1) {
    if (betaInside)
      return EdgeEdgeType::AB1;
    return beta >= alpha ? EdgeEdgeType::A1B0
                         : (beta >= 0 ? EdgeEdgeType::A1B1 : EdgeEdgeType::A1B);
  }
  return EdgeEdgeType::AB0;
}

/// Closest features of two segments: the minimiser over the (s, t) square
/// of the two lines' distance, clamped to its edges (the classic
/// segment-segment algorithm), with near-parallel edges set apart.
YASPS_HD inline EdgeEdgeType edgeEdgeType(Vec3 a0, Vec3 a1, Vec3 b0, Vec3 b1) {
  // Relative to |u|^2 |v|^2, a squared cross product below this is parallel.
  constexpr double kParallel = 2.5e-16;
  Vec3 u = a1 - a0, v = b1 - b0, w = a0 - b0;
  double a = dot(u, u), b = dot(u, v), c = dot(v, v);
  double d = dot(u, w), e = dot(v, w);
  double det = a * c - b * b;
  if (a == 0 && c == 0)
    return EdgeEdgeType::A0B0;
  if (a == 0)
    return EdgeEdgeType::A0B;
  if (c == 0)
    return EdgeEdgeType::AB0;
  if (squaredNorm(cross(u, v)) < kParallel * a * c)
    return parallelEdgeEdgeType(a0, a1, b0, b1);

  // s along a, t along b: s = sN / det inside, else clamped to an end of a,
  // where t is then tN / tD.
  double sN = b * e - c * d, tN, tD;
  EdgeEdgeType inside = EdgeEdgeType::AB;
  if (sN <= 0) {
    tN = e, tD = c, inside = EdgeEdgeType::A0B;
  } else if (sN >= det) {
    tN = e + b, tD = c, inside = EdgeEdgeType::A1B;
  } else {
    tN = a * e - b * d, tD = det;
  }
  if (tN <= 0) {
    // t clamped to b0: a's closest point to b0 is at -d / a.
    if (-d <= 0)
      return EdgeEdgeType::A0B0;
    return -d >= a ? EdgeEdgeType::A1B0 : EdgeEdgeType::AB0;
  }
  if (tN >= tD) {
    // t clamped to b1: a's closest point to b1 is at (b - d) / a.
    if (b - d <= 0)
      return EdgeEdgeType::A0B1;
    return b - d >= a ? EdgeEdgeType::A1B1 : EdgeEdgeType::AB1;
  }
  return inside;
}

YASPS_HD inline double edgeEdgeDistance2(Vec3 a0, Vec3 a1, Vec3 b0, Vec3 b1,
                                         EdgeEdgeType type) {
  switch (type) {
  case EdgeEdgeType::A0B0:
    return squaredNorm(a0 - b0);
  case EdgeEdgeType::A0B1:
    return squaredNorm(a0 - b1);
  case EdgeEdgeType::A1B0:
    return squaredNorm(a1 - b0);
  case EdgeEdgeType::A1B1:
    return squaredNorm(a1 - b1);
  case EdgeEdgeType::AB0:
    return pointLineDistance2(b0, a0, a1);
  case EdgeEdgeType::AB1:
    return pointLineDistance2(b1, a0, a1);
  case EdgeEdgeType::A0B:
    return pointLineDistance2(a0, b0, b1);
  case EdgeEdgeType::A1B:
    return pointLineDistance2(a1, b0, b1);
  case EdgeEdgeType::AB:
    break;
  }
  return lineLineDistance2(a0, a1, b0, b1);
}

YASPS_HD inline double edgeEdgeDistance2(Vec3 a0, Vec3 a1, Vec3 b0, Vec3 b1) {
  return edgeEdgeDistance2(a0, a1, b0, b1, edgeEdgeType(a0, a1, b0, b1));
}

/// IPC's threshold of the edge-edge mollifier, from the edges' squared rest
/// lengths: 1e-3 |a_rest|^2 |b_rest|^2.
YASPS_HD inline double edgeEdgeMollifierThreshold(double restLengthA2,
                                                  double restLengthB2) {
  return 1e-3 * restLengthA2 * restLengthB2;
}

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_CONTACT_DISTANCE_H
