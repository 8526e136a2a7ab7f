//===- BenchMain.h - the main() of the runtime's benchmark tools ----------===//

#ifndef YASPS_RUNTIME_BENCH_BENCHMAIN_H
#define YASPS_RUNTIME_BENCH_BENCHMAIN_H

#include <exception>
#include <iostream>

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

} // namespace yasps::runtime::bench

#endif // YASPS_RUNTIME_BENCH_BENCHMAIN_H
