//===- AdditiveCcd.h - the largest step that keeps surfaces apart -*- C++ -*-=//
//
// IPC's additive CCD (Li, Kaufman and Jiang 2021, "Codimensional Incremental
// Potential Contact", Algorithm 1) over a step's candidates: each pair
// advances along the straight motion by steps that cannot close more than
// the distance left (bounded by the largest relative displacement), and
// stops once the distance has shrunk to (1 - rescaling) of what it was.
// Fast, and exact for the barrier's purposes away from rounding: once the
// distance nears the coordinates' last digits nothing is provable, which
// the caller guards against by a minimum separation (and by a provably
// conservative CCD where pairs are already that close).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_CONTACT_ADDITIVECCD_H
#define YASPS_RUNTIME_CONTACT_ADDITIVECCD_H

#include "yasps/Runtime/Contact/BroadPhase.h"

namespace yasps::runtime::contact {

/// ipctk's default: a pair stops where its distance has closed by 90%.
constexpr double kAdditiveCcdRescaling = 0.9;

/// What additiveStepBound finds: the largest safe fraction of the motion,
/// and the smallest squared distance among the candidates at its start
/// (every pair's CCD measures it first; inf without candidates).
struct StepBound {
  double fraction;
  double minDistance2;
};

/// The largest fraction in [0, 1] of the straight motion v0 -> v1 along
/// which no candidate pair comes closer than `minDistance` (0 where a pair
/// is that close already), and the candidates' closest squared distance at
/// v0, the same whatever `pool` (nullptr: this thread alone) runs the
/// pairs.
StepBound additiveStepBound(const SurfaceMesh &mesh,
                            const Candidates &candidates, Positions v0,
                            Positions v1, double minDistance,
                            double rescaling = kAdditiveCcdRescaling,
                            ThreadPool *pool = nullptr);

/// The smallest squared distance among the candidate pairs at `v` (by
/// their closest features), inf without candidates.
double candidateMinDistance2(const SurfaceMesh &mesh,
                             const Candidates &candidates, Positions v);

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_CONTACT_ADDITIVECCD_H
