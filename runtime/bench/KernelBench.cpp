//===- KernelBench.cpp - timing compiled yasps kernels on a GPU -----------===//
//
// yasps-kernel-bench KIT [--repeat N] [--no-check]
//
// Runs the GPU kernels of a kit (Kit.h; written by bench/gpu_kit.py: a
// scene's derivative kernels as cubins and PTX, with the compiler's
// recorded launch ABI and the scene's input buffers), checks each output's
// first instances against the CPU kernels' values, and prints the time per
// launch over all instances. Needs no MLIR or Python, so that kernels
// compiled here can be timed on a GPU machine without this toolchain.
//
//===----------------------------------------------------------------------===//

#include "BenchMain.h"
#include "Kit.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>

using namespace yasps::runtime;
using namespace yasps::runtime::bench;

namespace {

int run(int argc, char **argv) {
  if (argc < 2) {
    std::cerr << "usage: yasps-kernel-bench KIT [--repeat N] [--no-check]\n";
    return 2;
  }
  int repeat = 50;
  bool check = true;
  for (int a = 2; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc)
      repeat = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--no-check"))
      check = false; // for running the launches where kernels do not run
  }
  Kit kit = readKit(argv[1]);
  CudaDriver &driver = CudaDriver::get();
  driver.requireUsable();
  CudaContext context(driver, 0);
  KitRunner runner(kit, context);
  const CudaDeviceInfo &device = driver.devices()[0];
  std::printf("%s (%s, %s %s)\n", device.name.c_str(), device.chip().c_str(),
              runner.selectedImage().chip.c_str(),
              runner.selectedImage().format.c_str());
  std::fflush(stdout);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  int failures = 0; // a mismatch is reported; the other kernels still run
  for (const KitKernel &kernel : kit.kernels) {
    runner.launch(kernel);
    context.synchronize();
    double difference = runner.differenceFromReference(kernel);
    auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < repeat; ++k)
      runner.launch(kernel);
    context.synchronize();
    double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count() /
        repeat;
    std::printf("  %-10s %10.4f ms  (%lld instances; the first values within "
                "%.1e of the CPU's)\n",
                kernel.label.c_str(), seconds * 1e3, (long long)kernel.count,
                difference);
    if (check && !(difference <= 1e-10)) {
      std::printf("  FAILED: %s differs from the CPU\n", kernel.label.c_str());
      ++failures;
    }
  }
  return failures ? 1 : 0;
}

} // namespace

int main(int argc, char **argv) {
  return runReportingErrors("yasps-kernel-bench", run, argc, argv);
}
