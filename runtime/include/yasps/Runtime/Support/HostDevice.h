//===- HostDevice.h - code compiled for both the host and the GPU -*- C++ -*-=//
//
// The GPU solver's kernels (lib/Gpu/SolverKernels.cu, built by nvcc) and
// the host code that checks them share their per-thread bodies. This header
// gives those bodies what differs between the two compilations: the
// function qualifiers, the few math functions they use and atomic addition.
// On the host, atomicAddDouble is atomic too: the tests' stand-in driver
// may run a block's threads on concurrent OS threads (OsThreadTeam.h).
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SUPPORT_HOSTDEVICE_H
#define YASPS_RUNTIME_SUPPORT_HOSTDEVICE_H

#if defined(__CUDACC__)
#define YASPS_HD __host__ __device__
#else
#define YASPS_HD
#include <cmath>
#endif

namespace yasps::runtime {

YASPS_HD inline double hdSqrt(double x) {
#if defined(__CUDA_ARCH__)
  return ::sqrt(x);
#else
  return std::sqrt(x);
#endif
}

YASPS_HD inline double hdNaN() {
#if defined(__CUDA_ARCH__)
  return ::nan("");
#else
  return std::nan("");
#endif
}

YASPS_HD inline double hdFabs(double x) { return x < 0.0 ? -x : x; }

/// False for NaN and infinities (x - x is NaN for both). Needs IEEE
/// semantics: neither compilation uses fast-math.
YASPS_HD inline bool hdIsFinite(double x) { return x - x == 0.0; }

/// *target += value, atomically.
YASPS_HD inline void atomicAddDouble(double *target, double value) {
#if defined(__CUDA_ARCH__)
  atomicAdd(target, value);
#else
  double expected;
  __atomic_load(target, &expected, __ATOMIC_RELAXED);
  double desired = expected + value;
  while (!__atomic_compare_exchange(target, &expected, &desired,
                                    /*weak=*/true, __ATOMIC_RELAXED,
                                    __ATOMIC_RELAXED))
    desired = expected + value;
#endif
}

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SUPPORT_HOSTDEVICE_H
