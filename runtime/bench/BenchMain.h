//===- BenchMain.h - what the runtime's benchmark tools share -------------===//

#ifndef YASPS_RUNTIME_BENCH_BENCHMAIN_H
#define YASPS_RUNTIME_BENCH_BENCHMAIN_H

#include <algorithm>
#include <cmath>
#include <exception>
#include <iostream>
#include <vector>

namespace yasps::runtime::bench {

/// Runs `run`, reporting an exception as "TOOL: message" on stderr with
/// exit status 1.
inline int runReportingErrors(const char *tool, int (*run)(int, char **),
                              int argc, char **argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception &error) {
    std::cerr << tool << ": " << error.what() << "\n";
    return 1;
  }
}

/// The largest difference of got[0, n) from want[0, n), relative to want's
/// largest magnitude (absolute when want is zero).
inline double relativeDifference(const double *got, const double *want,
                                 std::size_t n) {
  double diff = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    diff = std::max(diff, std::fabs(got[i] - want[i]));
    scale = std::max(scale, std::fabs(want[i]));
  }
  return scale > 0 ? diff / scale : diff;
}

inline double relativeDifference(const std::vector<double> &got,
                                 const std::vector<double> &want) {
  return relativeDifference(got.data(), want.data(), want.size());
}

} // namespace yasps::runtime::bench

#endif // YASPS_RUNTIME_BENCH_BENCHMAIN_H
