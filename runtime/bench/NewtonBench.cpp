//===- NewtonBench.cpp - one Newton iteration on the GPU, in stages -------===//
//
// yasps-newton-bench KIT [--repeat N]
//
// Runs one Newton iteration of the scene of a kit (Kit.h; bench/gpu_kit.py
// writes the bunny's: stable Neo-Hookean + inertia) on the GPU, stage by
// stage, as minimizeEnergy does on the GPU backend: the energies'
// gradient and projected-Hessian kernels, the placement-index kernels
// (copied back), the block structure (built on the host), its upload,
// assembly on the device and block-Jacobi PCG on the device. Every kernel
// output is checked against the CPU kernels' first values and the Newton
// direction (solved to the kit's tight tolerance) against the CPU's; then
// the stages are timed, PCG at the paper's relative tolerance 1e-4 after a
// warm-up solve, and the CPU's assembly and PCG on the same derivatives
// beside them. Each stage is printed as soon as it is measured, and a
// failed check is reported and counted rather than ending the run (exit
// status 1 at the end), so that a GPU window is not lost to the first
// mismatch. Needs no MLIR or Python.
//
//===----------------------------------------------------------------------===//

#include "BenchMain.h"
#include "Kit.h"

#include "yasps/Runtime/Gpu/GpuSystem.h"
#include "yasps/Runtime/Sparse/PcgSolver.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <thread>

using namespace yasps::runtime;
using namespace yasps::runtime::bench;

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

int run(int argc, char **argv) {
  if (argc < 2) {
    std::cerr << "usage: yasps-newton-bench KIT [--repeat N]\n";
    return 2;
  }
  int repeat = 10;
  bool check = true;
  double tolerance = 1e-4; // the paper's and the CPU tables' PCG tolerance
  for (int a = 2; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc)
      repeat = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--no-check"))
      check = false; // for running the stages where kernels do not run
    else if (!std::strcmp(argv[a], "--tolerance") && a + 1 < argc)
      tolerance = std::atof(argv[++a]);
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  Kit kit = readKit(argv[1]);
  if (kit.energies.empty() || kit.layout.empty() || kit.solution.empty())
    throw std::runtime_error(std::string(argv[1]) +
                             " is not a Newton kit (no energy, layout or "
                             "solution)");
  CudaDriver &driver = CudaDriver::get();
  driver.requireUsable();
  CudaContext context(driver, 0);
  KitRunner runner(kit, context);
  const CudaDeviceInfo &device = driver.devices()[0];
  std::printf("one Newton iteration on %s (%s)\n", device.name.c_str(),
              device.chip().c_str());
  auto sync = [&] { context.synchronize(); };
  int failures = 0;
  auto differs = [&](const KitKernel &kernel) {
    double difference = runner.differenceFromReference(kernel);
    if (check && !(difference <= 1e-10)) {
      std::printf("  FAILED: %s differs from the CPU by %.3g\n",
                  kernel.label.c_str(), difference);
      ++failures;
    }
    return difference;
  };
  double largest = 0.0;
  auto stage = [](const char *name, double seconds) {
    std::printf("  %-34s %10.3f ms\n", name, seconds * 1e3);
  };

  // Derivatives: gradient and projected Hessian kernels of every energy.
  auto derivatives = [&] {
    for (const KitEnergy &e : kit.energies) {
      runner.launch(kit.kernel(e.grad));
      runner.launch(kit.kernel(e.hessian));
    }
    sync();
  };
  derivatives();
  for (const KitEnergy &e : kit.energies)
    largest = std::max(
        {largest, differs(kit.kernel(e.grad)), differs(kit.kernel(e.hessian))});
  Clock::time_point start = Clock::now();
  for (int k = 0; k < repeat; ++k)
    derivatives();
  stage("derivatives (GPU kernels)", secondsSince(start) / repeat);

  // Indices: the placement-index kernels, copied back for the structure.
  start = Clock::now();
  std::vector<std::vector<std::int64_t>> dofs;
  for (const KitEnergy &e : kit.energies) {
    const KitKernel &kernel = kit.kernel(e.dofs);
    runner.launch(kernel);
    std::vector<double> oneBased(kernel.outValues);
    runner.output(kernel).download(oneBased.data(),
                                   oneBased.size() * sizeof(double));
    dofs.emplace_back(oneBased.size());
    for (std::size_t i = 0; i < oneBased.size(); ++i)
      dofs.back()[i] = static_cast<std::int64_t>(oneBased[i]) - 1;
  }
  stage("indices (GPU kernels, copied back)", secondsSince(start));
  for (const KitEnergy &e : kit.energies)
    largest = std::max(largest, differs(kit.kernel(e.dofs)));
  std::printf("  kernels within %.1e of the CPU's\n", largest);

  // The block structure, on the host, and its upload.
  Npy offsets = readNpy(kit.dir + "/" + kit.layout);
  BlockLayout layout{std::vector<std::int64_t>(
      offsets.as<std::int64_t>(), offsets.as<std::int64_t>() + offsets.size())};
  std::vector<DofMap> maps;
  for (std::size_t k = 0; k < kit.energies.size(); ++k)
    maps.push_back(
        {kit.energies[k].count, kit.energies[k].numParams, dofs[k].data()});
  start = Clock::now();
  GlobalSystem host(layout, maps);
  stage("block structure (host, first time)", secondsSince(start));
  start = Clock::now();
  GpuSystem gpu(context, host);
  sync();
  stage("structure upload", secondsSince(start));
  std::printf("  %lld DoFs, %zu stored blocks\n", (long long)host.size(),
              gpu.storedBlocks());

  // Assembly and PCG on the device.
  auto assemble = [&] {
    gpu.setZero();
    for (std::size_t k = 0; k < kit.energies.size(); ++k)
      gpu.add(k, runner.output(kit.kernel(kit.energies[k].grad)).pointer(),
              runner.output(kit.kernel(kit.energies[k].hessian)).pointer());
    sync();
  };
  assemble();
  start = Clock::now();
  for (int k = 0; k < repeat; ++k)
    assemble();
  double assemblySeconds = secondsSince(start) / repeat;
  stage("assembly (GPU)", assemblySeconds);

  // The Newton direction, to the kit's tight tolerance, against the CPU's.
  PcgOptions tight;
  tight.relativeTolerance = kit.tolerance;
  tight.maxIterations = 10000;
  DeviceBuffer x(context, host.size() * sizeof(double));
  PcgResult solved = gpu.solve(x.pointer(), tight);
  std::vector<double> direction(host.size());
  x.download(direction.data(), direction.size() * sizeof(double));
  Npy want = readNpy(kit.dir + "/" + kit.solution);
  double solutionDifference =
      relativeDifference(direction.data(), want.as<double>(), direction.size());
  std::printf("  PCG to %.0e: %lld iterations to %.1e; Newton direction "
              "within %.1e of the CPU's\n",
              kit.tolerance, (long long)solved.iterations,
              solved.relativeResidual, solutionDifference);
  if (check && !(solved.converged && solutionDifference <= 1e-6)) {
    std::printf("  FAILED: the GPU's Newton direction differs from the "
                "CPU's\n");
    ++failures;
  }

  // PCG at the working tolerance, timed after a warm-up solve.
  PcgOptions options = tight;
  options.relativeTolerance = tolerance;
  gpu.solve(x.pointer(), options);
  start = Clock::now();
  PcgResult timed = gpu.solve(x.pointer(), options);
  double solveSeconds = secondsSince(start);
  std::printf("  %-34s %10.3f ms   (%lld iterations to %.1e)\n",
              "PCG (GPU, block-Jacobi)", solveSeconds * 1e3,
              (long long)timed.iterations, timed.relativeResidual);

  // The CPU's assembly and PCG on the same derivatives, every core.
  unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  ThreadPool pool(cores);
  std::vector<std::vector<double>> gradients, hessians;
  for (const KitEnergy &e : kit.energies) {
    for (const std::string &label : {e.grad, e.hessian}) {
      const KitKernel &kernel = kit.kernel(label);
      std::vector<double> values(kernel.outValues);
      runner.output(kernel).download(values.data(),
                                     values.size() * sizeof(double));
      (label == e.grad ? gradients : hessians).push_back(std::move(values));
    }
  }
  start = Clock::now();
  host.setZero();
  for (std::size_t k = 0; k < kit.energies.size(); ++k)
    host.add(k, gradients[k].data(), hessians[k].data(), &pool);
  double cpuAssembly = secondsSince(start);
  std::vector<double> cpuDirection(host.size());
  PcgSolver hostSolver;
  hostSolver.solve(host.hessianParts(), host.gradient().data(),
                   cpuDirection.data(), options, pool);
  start = Clock::now();
  PcgResult cpuSolved =
      hostSolver.solve(host.hessianParts(), host.gradient().data(),
                       cpuDirection.data(), options, pool);
  double cpuSolve = secondsSince(start);
  std::printf("  %-34s %10.3f ms   (%.1fx the GPU's)\n", "CPU assembly",
              cpuAssembly * 1e3, cpuAssembly / assemblySeconds);
  std::printf("  %-34s %10.3f ms   (%u threads, %lld iterations; %.1fx the "
              "GPU's)\n",
              "CPU PCG (block-Jacobi)", cpuSolve * 1e3, cores,
              (long long)cpuSolved.iterations, cpuSolve / solveSeconds);
  if (failures)
    std::printf("%d check(s) FAILED\n", failures);
  return failures ? 1 : 0;
}

} // namespace

int main(int argc, char **argv) {
  return runReportingErrors("yasps-newton-bench", run, argc, argv);
}
