//===- SpmvBench.cpp - the Newton system's SpMV and PCG, CPU and GPU ------===//
//
// yasps-spmv-bench MESH.msh [--repeat N] [--export DIR]
//
// Builds the block structure of a tet mesh's Newton system as the bunny
// benchmarks do (a 12-parameter energy per tet, such as stable
// Neo-Hookean, and a 3-parameter one per vertex, such as inertia), fills it
// with random positive definite local Hessians and times, on the CPU and,
// where there is one, on the GPU: assembly, the block-sparse SpMV, and
// block-Jacobi and multilevel PCG solves; on the GPU also a device-to-device
// copy, for the bandwidth bound of the SpMV's bytes. Results are checked
// against the CPU before they are timed. `--export DIR` writes the whole matrix
// as CSR, a vector and its product as .npy files for bench/gpu_cusparse.py,
// which times cuSPARSE on the same matrix.
//
// Needs no MLIR or Python: the binary can be carried to a GPU machine.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Assembly/GlobalSystem.h"
#include "yasps/Runtime/Gpu/GpuSystem.h"
#include "yasps/Runtime/Sparse/PcgSolver.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include "BenchMain.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <thread>

using namespace yasps::runtime;
using namespace yasps::runtime::bench;

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Seconds per call of `fn` over `repeat` calls after one warm-up;
/// `finish` waits for queued work (the GPU) at both ends.
template <typename Fn, typename Finish>
double perCall(int repeat, Fn &&fn, Finish &&finish) {
  fn();
  finish();
  Clock::time_point start = Clock::now();
  for (int k = 0; k < repeat; ++k)
    fn();
  finish();
  return secondsSince(start) / repeat;
}

struct Mesh {
  std::int64_t numVertices = 0;
  std::vector<std::int64_t> tets; // 4 per tet, 0-based
};

/// The 4-node tets of a Gmsh 2.2 ASCII file.
Mesh readGmshTets(const std::string &path) {
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot read " + path);
  Mesh mesh;
  std::string line;
  std::vector<std::int64_t> index; // node id -> vertex
  while (std::getline(in, line)) {
    if (line == "$Nodes") {
      std::getline(in, line);
      mesh.numVertices = std::stoll(line);
      for (std::int64_t v = 0; v < mesh.numVertices; ++v) {
        std::getline(in, line);
        std::int64_t id = std::stoll(line);
        if (id >= std::int64_t(index.size()))
          index.resize(id + 1, -1);
        index[id] = v;
      }
    } else if (line == "$Elements") {
      std::getline(in, line);
      std::int64_t count = std::stoll(line);
      for (std::int64_t e = 0; e < count; ++e) {
        std::getline(in, line);
        std::istringstream fields(line);
        std::int64_t id, type, tags;
        fields >> id >> type >> tags;
        for (std::int64_t t = 0; t < tags; ++t)
          fields >> id;
        if (type != 4)
          continue;
        for (int k = 0; k < 4; ++k) {
          std::int64_t node;
          fields >> node;
          mesh.tets.push_back(index.at(node));
        }
      }
    }
  }
  if (mesh.tets.empty())
    throw std::runtime_error(path + " has no tetrahedra");
  return mesh;
}

/// `count` random symmetric positive definite n x n matrices (A A^T / n +
/// I / 10, row-major) and gradients.
void randomLocal(std::mt19937 &rng, std::int64_t count, std::int64_t n,
                 std::vector<double> &gradients,
                 std::vector<double> &hessians) {
  std::normal_distribution<double> normal;
  gradients.resize(count * n);
  for (double &g : gradients)
    g = normal(rng);
  hessians.resize(count * n * n);
  std::vector<double> a(n * n);
  for (std::int64_t i = 0; i < count; ++i) {
    for (double &v : a)
      v = normal(rng);
    double *h = &hessians[i * n * n];
    for (std::int64_t r = 0; r < n; ++r)
      for (std::int64_t c = 0; c < n; ++c) {
        double s = r == c ? 0.1 : 0.0;
        for (std::int64_t k = 0; k < n; ++k)
          s += a[r * n + k] * a[c * n + k] / double(n);
        h[r * n + c] = s;
      }
  }
}

/// Writes a 1-D .npy array (`descr`: "<f8", "<i8").
template <typename T>
void writeNpy(const std::string &path, const std::vector<T> &data,
              const char *descr) {
  std::ofstream out(path, std::ios::binary);
  if (!out)
    throw std::runtime_error("cannot write " + path);
  std::string header = std::string("{'descr': '") + descr +
                       "', 'fortran_order': False, 'shape': (" +
                       std::to_string(data.size()) + ",), }";
  // Magic, version 1.0, header padded so that data starts at 64 bytes k.
  std::size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  unsigned short length = static_cast<unsigned short>(header.size());
  out.write("\x93NUMPY\x01\x00", 8);
  out.write(reinterpret_cast<const char *>(&length), 2);
  out.write(header.data(), header.size());
  out.write(reinterpret_cast<const char *>(data.data()),
            data.size() * sizeof(T));
  if (!out)
    throw std::runtime_error("cannot write " + path);
}

/// The whole matrix (both triangles, both parts) as CSR.
void exportCsr(const GlobalSystem &system, const std::vector<double> &x,
               const std::vector<double> &y, const std::string &dir) {
  std::filesystem::create_directories(dir);
  std::int64_t n = system.size();
  std::vector<std::vector<std::pair<std::int64_t, double>>> rows(n);
  for (const BlockSparseMatrix *H : system.hessianParts()) {
    const BlockLayout &layout = H->layout();
    for (std::size_t b = 0; b < H->numStoredBlocks(); ++b) {
      std::int64_t r = H->blockRow(b), c = H->blockCol(b);
      std::int64_t nr = layout.blockSize(r), nc = layout.blockSize(c);
      const double *data = H->blockData(b);
      for (std::int64_t i = 0; i < nr; ++i)
        for (std::int64_t j = 0; j < nc; ++j) {
          std::int64_t gi = layout.blockOffset[r] + i,
                       gj = layout.blockOffset[c] + j;
          rows[gi].emplace_back(gj, data[i * nc + j]);
          if (r != c)
            rows[gj].emplace_back(gi, data[i * nc + j]);
        }
    }
  }
  std::vector<std::int64_t> indptr{0}, indices;
  std::vector<double> values;
  for (auto &row : rows) {
    std::sort(row.begin(), row.end());
    for (std::size_t k = 0; k < row.size(); ++k) {
      // Entries of both parts at one place are summed.
      if (k > 0 && row[k].first == row[k - 1].first) {
        values.back() += row[k].second;
        continue;
      }
      indices.push_back(row[k].first);
      values.push_back(row[k].second);
    }
    indptr.push_back(static_cast<std::int64_t>(indices.size()));
  }
  writeNpy(dir + "/indptr.npy", indptr, "<i8");
  writeNpy(dir + "/indices.npy", indices, "<i8");
  writeNpy(dir + "/values.npy", values, "<f8");
  writeNpy(dir + "/x.npy", x, "<f8");
  writeNpy(dir + "/y.npy", y, "<f8");
}

int run(int argc, char **argv) {
  if (argc < 2) {
    std::cerr << "usage: yasps-spmv-bench MESH.msh [--repeat N] "
                 "[--export DIR]\n";
    return 2;
  }
  int repeat = 50;
  std::string exportDir;
  for (int a = 2; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--repeat") && a + 1 < argc)
      repeat = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--export") && a + 1 < argc)
      exportDir = argv[++a];
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  Mesh mesh = readGmshTets(argv[1]);
  const std::int64_t numTets = std::int64_t(mesh.tets.size() / 4);
  const std::int64_t nv = mesh.numVertices;
  std::vector<std::int64_t> tetDofs, vertexDofs;
  for (std::int64_t v : mesh.tets)
    for (int c = 0; c < 3; ++c)
      tetDofs.push_back(3 * v + c);
  for (std::int64_t d = 0; d < 3 * nv; ++d)
    vertexDofs.push_back(d);

  Clock::time_point start = Clock::now();
  GlobalSystem system(
      BlockLayout::fromSizes(std::vector<std::int64_t>(nv, 3)),
      {{numTets, 12, tetDofs.data()}, {nv, 3, vertexDofs.data()}});
  double structure = secondsSince(start);
  std::mt19937 rng(0);
  std::vector<double> gt, ht, gv, hv;
  randomLocal(rng, numTets, 12, gt, ht);
  randomLocal(rng, nv, 3, gv, hv);
  unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  ThreadPool one(1), all(cores);
  auto assembleCpu = [&](ThreadPool *pool) {
    system.setZero();
    system.add(0, gt.data(), ht.data(), pool);
    system.add(1, gv.data(), hv.data(), pool);
  };
  auto nothing = [] {};
  double assembleOne = perCall(
      std::max(repeat / 10, 2), [&] { assembleCpu(&one); }, nothing);
  double assembleAll = perCall(
      std::max(repeat / 10, 2), [&] { assembleCpu(&all); }, nothing);
  assembleCpu(nullptr);

  const std::int64_t n = system.size();
  std::vector<double> x(n), y(n);
  std::normal_distribution<double> normal;
  for (double &v : x)
    v = normal(rng);
  double spmvOne = perCall(
      repeat, [&] { system.multiply(x.data(), y.data(), one); }, nothing);
  double spmvAll = perCall(
      repeat, [&] { system.multiply(x.data(), y.data(), all); }, nothing);
  PcgOptions options;
  options.relativeTolerance = 1e-8;
  PcgSolver solver;
  auto solve = [&](double *x, const PcgOptions &o, ThreadPool &pool) {
    return solver.solve(system.hessianParts(), system.gradient().data(), x, o,
                        pool);
  };
  std::vector<double> solution(n);
  start = Clock::now();
  PcgResult cpuSolve = solve(solution.data(), options, all);
  double solveAll = secondsSince(start);
  // One thread, per iteration, beside the one-thread SpMV: what the rest
  // of an iteration (preconditioner, vector steps) adds to it. A fixed 100
  // iterations (a tolerance never met), so that the solve's setup is a
  // small part.
  PcgOptions hundred = options;
  hundred.relativeTolerance = 0.0;
  hundred.maxIterations = 100;
  std::vector<double> scratch(n);
  start = Clock::now();
  PcgResult oneSolve = solve(scratch.data(), hundred, one);
  double solveOne = secondsSince(start);
  // The multilevel preconditioner: a first solve builds the levels'
  // structure, the second (timed) reuses it, as Newton iterations do.
  PcgOptions multilevel = options;
  multilevel.preconditioner = PcgPreconditioner::Multilevel;
  std::vector<double> levelSolution(n);
  solve(levelSolution.data(), multilevel, all);
  start = Clock::now();
  PcgResult cpuLevels = solve(levelSolution.data(), multilevel, all);
  double levelsAll = secondsSince(start);
  std::size_t stored = system.staticHessian().numStoredBlocks() +
                       system.dynamicHessian().numStoredBlocks();

  std::printf("Newton system of %s: %lld vertices, %lld tets, %lld DoFs, "
              "%zu stored upper 3x3 blocks\n",
              argv[1], (long long)nv, (long long)numTets, (long long)n, stored);
  std::printf("  CPU structure (first iteration)  %9.3f ms\n", structure * 1e3);
  std::printf("  CPU assembly    1 thread %9.3f ms, %u threads %9.3f ms\n",
              assembleOne * 1e3, cores, assembleAll * 1e3);
  std::printf("  CPU SpMV        1 thread %9.3f ms, %u threads %9.3f ms\n",
              spmvOne * 1e3, cores, spmvAll * 1e3);
  std::printf("  CPU PCG 1 thread: %9.3f ms per iteration (%lld iterations)\n",
              solveOne * 1e3 / std::max<std::int64_t>(oneSolve.iterations, 1),
              (long long)oneSolve.iterations);
  std::printf("  CPU PCG (%u threads) %lld iterations to %.1e: %9.3f ms\n",
              cores, (long long)cpuSolve.iterations, cpuSolve.relativeResidual,
              solveAll * 1e3);
  std::printf("  CPU multilevel PCG (%u threads, %lld levels) %lld iterations "
              "to %.1e: %9.3f ms, solutions within %.1e\n",
              cores, (long long)cpuLevels.levels,
              (long long)cpuLevels.iterations, cpuLevels.relativeResidual,
              levelsAll * 1e3, relativeDifference(levelSolution, solution));
  if (!exportDir.empty()) {
    exportCsr(system, x, y, exportDir);
    std::printf("  matrix, x and y = H x written to %s (CSR, .npy)\n",
                exportDir.c_str());
  }

  CudaDriver &driver = CudaDriver::get();
  if (!driver.usable()) {
    std::printf("  GPU: not run: %s\n", driver.unusableReason().c_str());
    return 1; // asked for a GPU benchmark and none ran
  }
  CudaContext context(driver, 0);
  GpuSystem gpu(context, system);
  DeviceBuffer dgt = deviceCopy(context, gt), dht = deviceCopy(context, ht),
               dgv = deviceCopy(context, gv), dhv = deviceCopy(context, hv),
               dx = deviceCopy(context, x);
  DeviceBuffer dy(context, n * sizeof(double)),
      dsol(context, n * sizeof(double));
  auto assembleGpu = [&] {
    gpu.setZero();
    gpu.add(0, dgt.pointer(), dht.pointer());
    gpu.add(1, dgv.pointer(), dhv.pointer());
  };
  auto sync = [&] { context.synchronize(); };
  double assembleGpuTime = perCall(std::max(repeat / 10, 2), assembleGpu, sync);
  double check =
      relativeDifference(gpu.hessianValues(0), system.staticHessian().values());
  gpu.multiply(dx.pointer(), dy.pointer());
  std::vector<double> gy(n);
  dy.download(gy.data(), n * sizeof(double));
  check = std::max(check, relativeDifference(gy, y));
  // A mismatch is reported and the timings still run, so that one failed
  // check does not cost the rest of a GPU window.
  bool failed = !(check < 1e-10);
  if (failed)
    std::printf("  FAILED: GPU results differ from the CPU's: %.3g relative\n",
                check);
  double spmvGpu = perCall(
      repeat, [&] { gpu.multiply(dx.pointer(), dy.pointer()); }, sync);
  // Bandwidth: a device-to-device copy of 512 MiB, bytes read and written.
  std::size_t copyBytes = std::size_t(512) << 20;
  DeviceBuffer from(context, copyBytes), to(context, copyBytes);
  double copy = perCall(
      20, [&] { to.copyFrom(from, copyBytes); }, sync);
  double bandwidth = 2.0 * double(copyBytes) / copy;
  double bound = double(gpu.multiplyBytes()) / bandwidth;
  start = Clock::now();
  PcgResult gpuSolve = gpu.solve(dsol.pointer(), options);
  double solveGpu = secondsSince(start);
  std::vector<double> gsol(n);
  dsol.download(gsol.data(), n * sizeof(double));
  gpu.solve(dsol.pointer(), multilevel);
  start = Clock::now();
  PcgResult gpuLevels = gpu.solve(dsol.pointer(), multilevel);
  double levelsGpu = secondsSince(start);
  std::vector<double> glsol(n);
  dsol.download(glsol.data(), n * sizeof(double));

  const CudaDeviceInfo &info = driver.devices()[0];
  std::printf("GPU %s (%s), results within %.1e of the CPU's\n",
              info.name.c_str(), info.chip().c_str(), check);
  std::printf("  GPU assembly                     %9.3f ms  (%.1fx the CPU's "
              "%u threads)\n",
              assembleGpuTime * 1e3, assembleAll / assembleGpuTime, cores);
  std::printf("  GPU SpMV                         %9.4f ms  (%.1fx the CPU's "
              "%u threads)\n",
              spmvGpu * 1e3, spmvAll / spmvGpu, cores);
  std::printf("  bandwidth bound: %.1f MiB at %.0f GB/s (device copy) = "
              "%.4f ms: the SpMV reaches %.0f%%\n",
              gpu.multiplyBytes() / 1048576.0, bandwidth / 1e9, bound * 1e3,
              100.0 * bound / spmvGpu);
  std::printf("  GPU PCG %lld iterations to %.1e: %9.3f ms (%.1fx the CPU's), "
              "solutions within %.1e\n",
              (long long)gpuSolve.iterations, gpuSolve.relativeResidual,
              solveGpu * 1e3, solveAll / solveGpu,
              relativeDifference(gsol, solution));
  std::printf("  GPU multilevel PCG %lld iterations to %.1e: %9.3f ms (%.1fx "
              "the GPU block-Jacobi's), solutions within %.1e\n",
              (long long)gpuLevels.iterations, gpuLevels.relativeResidual,
              levelsGpu * 1e3, solveGpu / levelsGpu,
              relativeDifference(glsol, solution));
  return failed ? 1 : 0;
}

} // namespace

int main(int argc, char **argv) {
  return yasps::runtime::bench::runReportingErrors("yasps-spmv-bench", run,
                                                   argc, argv);
}
