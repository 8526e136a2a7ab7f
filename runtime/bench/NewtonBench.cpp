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
// direction against the CPU's, then the stages are timed; the CPU's
// assembly and PCG on the same derivatives are timed for comparison.
// Needs no MLIR or Python.
//
//===----------------------------------------------------------------------===//

#include "BenchMain.h"
#include "Kit.h"

#include "yasps/Runtime/GpuSystem.h"
#include "yasps/Runtime/ThreadPool.h"

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
  for (int a = 2; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc)
      repeat = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--no-check"))
      check = false; // for running the stages where kernels do not run
  }
  Kit kit = readKit(argv[1]);
  if (kit.energies.empty() || kit.layout.empty() || kit.solution.empty())
    throw std::runtime_error(std::string(argv[1]) +
                             " is not a Newton kit (no energy, layout or "
                             "solution)");
  CudaDriver &driver = CudaDriver::get();
  driver.requireUsable();
  CudaContext context(driver, 0);
  KitRunner runner(kit, context);
  auto sync = [&] { context.synchronize(); };
  auto differs = [&](const KitKernel &kernel) {
    double difference = runner.differenceFromReference(kernel);
    if (check && !(difference <= 1e-10))
      throw std::runtime_error(kernel.label + " differs from the CPU by " +
                               std::to_string(difference));
    return difference;
  };
  double largest = 0.0;

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
  double derivativeSeconds = secondsSince(start) / repeat;

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
  double indexSeconds = secondsSince(start);
  for (const KitEnergy &e : kit.energies)
    largest = std::max(largest, differs(kit.kernel(e.dofs)));

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
  double structureSeconds = secondsSince(start);
  start = Clock::now();
  GpuSystem gpu(context, host);
  sync();
  double uploadSeconds = secondsSince(start);

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
  PcgOptions options;
  options.relativeTolerance = kit.tolerance;
  options.maxIterations = 10000;
  DeviceBuffer x(context, host.size() * sizeof(double));
  start = Clock::now();
  PcgResult solved = gpu.solve(x.pointer(), options);
  double solveSeconds = secondsSince(start);
  std::vector<double> direction(host.size());
  x.download(direction.data(), direction.size() * sizeof(double));
  Npy want = readNpy(kit.dir + "/" + kit.solution);
  double solutionDifference =
      relativeDifference(direction.data(), want.as<double>(), direction.size());
  if (check && !(solved.converged && solutionDifference <= 1e-6))
    throw std::runtime_error("the GPU's Newton direction differs from the "
                             "CPU's by " +
                             std::to_string(solutionDifference));

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
  start = Clock::now();
  PcgResult cpuSolved = host.solve(cpuDirection.data(), options, pool);
  double cpuSolve = secondsSince(start);

  const CudaDeviceInfo &device = driver.devices()[0];
  std::printf("one Newton iteration on %s (%s): %lld DoFs, %zu stored "
              "blocks; kernels within %.1e of the CPU's\n",
              device.name.c_str(), device.chip().c_str(),
              (long long)host.size(), gpu.storedBlocks(), largest);
  std::printf("  %-34s %10.3f ms\n", "derivatives (GPU kernels)",
              derivativeSeconds * 1e3);
  std::printf("  %-34s %10.3f ms\n", "indices (GPU kernels, copied back)",
              indexSeconds * 1e3);
  std::printf("  %-34s %10.3f ms\n", "block structure (host, first time)",
              structureSeconds * 1e3);
  std::printf("  %-34s %10.3f ms\n", "structure upload", uploadSeconds * 1e3);
  std::printf("  %-34s %10.3f ms   (CPU, %u threads: %.3f ms)\n",
              "assembly (GPU)", assemblySeconds * 1e3, cores,
              cpuAssembly * 1e3);
  std::printf("  %-34s %10.3f ms   (CPU: %.3f ms, %lld iterations)\n",
              "PCG (GPU)", solveSeconds * 1e3, cpuSolve * 1e3,
              (long long)cpuSolved.iterations);
  std::printf("  PCG: %lld iterations to %.1e; Newton direction within %.1e "
              "of the CPU's\n",
              (long long)solved.iterations, solved.relativeResidual,
              solutionDifference);
  return 0;
}

} // namespace

int main(int argc, char **argv) {
  return runReportingErrors("yasps-newton-bench", run, argc, argv);
}
