//===- GpuSystemTest.cpp - the Newton system on the GPU against the CPU ---===//
//
// Every test runs twice: against the stand-in driver (FakeCuda.cpp), which
// runs the solver kernels' bodies on the host, and against this machine's
// CUDA driver, where there is a GPU (skipped, saying why, where there is
// none). Both compare the GPU system with the CPU GlobalSystem on the same
// scene: mixed block sizes (3-DoF vertices, 2-DoF points, a 9-DoF and a
// 12-DoF body), so that specialised and generic SpMV kernels run, with more
// blocks than one CUDA block handles, repeated DoFs and padding.
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/Gpu/GpuSystem.h"
#include "Gpu/GpuSolverKernels.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include "FakeCudaDriver.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace yasps::runtime;

namespace {

constexpr int kVertices = 300, kPoints = 40;
// Block indices: vertices, then the 9-DoF body, the 12-DoF body, points.
constexpr int kBody9 = kVertices, kBody12 = kVertices + 1,
              kFirstPoint = kVertices + 2;

struct Energy {
  std::int64_t count = 0, n = 0;
  std::vector<std::int64_t> dofs;
  std::vector<double> gradients, hessians;
};

/// Appends the DoFs of block `b` of `layout`.
void appendBlock(const BlockLayout &layout, std::int64_t b,
                 std::vector<std::int64_t> &dofs) {
  for (std::int64_t d = layout.blockOffset[b]; d < layout.blockOffset[b + 1];
       ++d)
    dofs.push_back(d);
}

struct Scene {
  BlockLayout layout;
  std::vector<Energy> energies; // static: edges, bodies, points; dynamic
  std::mt19937 rng{7};

  Scene() {
    std::vector<std::int64_t> sizes(kVertices, 3);
    sizes.push_back(9);
    sizes.push_back(12);
    sizes.insert(sizes.end(), kPoints, 2);
    layout = BlockLayout::fromSizes(sizes);
    std::uniform_int_distribution<int> vertex(0, kVertices - 1);
    // Edges: a chain over all vertices, random pairs and self pairs
    // (repeated DoFs).
    Energy edges;
    edges.n = 6;
    auto edge = [&](int a, int b) {
      appendBlock(layout, a, edges.dofs);
      appendBlock(layout, b, edges.dofs);
      ++edges.count;
    };
    for (int v = 0; v + 1 < kVertices; ++v)
      edge(v, v + 1);
    for (int k = 0; k < 200; ++k)
      edge(vertex(rng), vertex(rng));
    for (int v = 0; v < 5; ++v)
      edge(v, v);
    // Bodies: a vertex with the 9-DoF body, then a padding slot.
    Energy bodies;
    bodies.n = 13;
    for (int k = 0; k < 30; ++k) {
      appendBlock(layout, vertex(rng), bodies.dofs);
      appendBlock(layout, kBody9, bodies.dofs);
      bodies.dofs.push_back(-1);
      ++bodies.count;
    }
    // Points: each 2-DoF point with the 12-DoF body and a vertex.
    Energy points;
    points.n = 17;
    for (int k = 0; k < kPoints; ++k) {
      appendBlock(layout, kBody12, points.dofs);
      appendBlock(layout, kFirstPoint + k, points.dofs);
      appendBlock(layout, vertex(rng), points.dofs);
      ++points.count;
    }
    energies = {edges, bodies, points, randomPairs(150)};
    for (Energy &e : energies)
      fill(e, 1.0);
  }

  Energy randomPairs(int count) {
    std::uniform_int_distribution<int> vertex(0, kVertices - 1);
    Energy pairs;
    pairs.n = 6;
    for (int k = 0; k < count; ++k) {
      appendBlock(layout, vertex(rng), pairs.dofs);
      appendBlock(layout, vertex(rng), pairs.dofs);
      ++pairs.count;
    }
    fill(pairs, 1.0);
    return pairs;
  }

  /// Random gradients and local Hessians `sign` (A A^T + I).
  void fill(Energy &e, double sign) {
    std::normal_distribution<double> normal;
    const std::int64_t n = e.n;
    e.gradients.resize(e.count * n);
    for (double &g : e.gradients)
      g = normal(rng);
    e.hessians.resize(e.count * n * n);
    std::vector<double> a(n * n);
    for (std::int64_t i = 0; i < e.count; ++i) {
      for (double &v : a)
        v = normal(rng);
      for (std::int64_t r = 0; r < n; ++r)
        for (std::int64_t c = 0; c < n; ++c) {
          double s = r == c ? 1.0 : 0.0;
          for (std::int64_t k = 0; k < n; ++k)
            s += a[r * n + k] * a[c * n + k];
          e.hessians[(i * n + r) * n + c] = sign * s;
        }
    }
  }

  std::vector<DofMap> maps(std::size_t begin, std::size_t end) const {
    std::vector<DofMap> out;
    for (std::size_t e = begin; e < end; ++e)
      out.push_back(
          {energies[e].count, energies[e].n, energies[e].dofs.data()});
    return out;
  }
};

std::vector<double> download(const DeviceBuffer &buffer) {
  std::vector<double> out(buffer.size() / sizeof(double));
  buffer.download(out.data(), buffer.size());
  return out;
}

void expectClose(const std::vector<double> &actual,
                 const std::vector<double> &expected, double relative,
                 const char *what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  double scale = 0.0;
  for (double v : expected)
    scale = std::max(scale, std::fabs(v));
  for (std::size_t i = 0; i < actual.size(); ++i)
    ASSERT_NEAR(actual[i], expected[i], relative * scale)
        << what << " entry " << i;
}

/// The drivers the tests run on: the stand-in running a block phase by
/// phase, running its threads as fibers that meet at barriers, or as OS
/// threads that meet at barriers; and this machine's.
enum class Driver { StandIn, StandInFibers, StandInOsThreads, ThisMachine };

#if defined(__SANITIZE_ADDRESS__)
#define YASPS_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define YASPS_TEST_ASAN 1
#endif
#endif

std::string driverName(const ::testing::TestParamInfo<Driver> &info) {
  switch (info.param) {
  case Driver::StandIn:
    return "StandIn";
  case Driver::StandInFibers:
    return "StandInFibers";
  case Driver::StandInOsThreads:
    return "StandInOsThreads";
  case Driver::ThisMachine:
    break;
  }
  return "ThisMachine";
}

test::BlockThreads blockThreadsOf(Driver driver) {
  return driver == Driver::StandInFibers      ? test::BlockThreads::Fibers
         : driver == Driver::StandInOsThreads ? test::BlockThreads::OsThreads
                                              : test::BlockThreads::Phases;
}

class GpuSystemTest : public ::testing::TestWithParam<Driver> {
protected:
  /// Whether this test runs on OS threads too: those whose kernels add
  /// atomically from many threads at once (assembly, SpMV), which only
  /// concurrent threads exercise, and that launch few blocks.
  static bool onOsThreads() {
    const std::string name =
        ::testing::UnitTest::GetInstance()->current_test_info()->name();
    for (const char *cheap :
         {"AssemblesLikeTheCpu/", "MultipliesLikeTheCpu/",
          "AssemblesFactoredHessians/", "ZeroRightHandSideIsSolvedAtOnce/",
          "RejectsMisuse/"})
      if (name.rfind(cheap, 0) == 0)
        return true;
    return false;
  }

  void SetUp() override {
    if (gpuSolverImages().empty())
      GTEST_SKIP() << "built without nvcc: no GPU solver kernels";
    if (GetParam() == Driver::ThisMachine) {
      driver = &CudaDriver::get();
      if (!driver->usable())
        GTEST_SKIP() << "no usable GPU: " << driver->unusableReason();
    } else {
#ifdef YASPS_TEST_ASAN
      // ThreadSanitizer does, told by FiberBlock.h.
      if (GetParam() == Driver::StandInFibers)
        GTEST_SKIP() << "AddressSanitizer does not follow swapcontext's "
                        "stack switches";
#endif
      if (GetParam() == Driver::StandInOsThreads && !onOsThreads())
        GTEST_SKIP() << "a solve with a block's 128 threads on as many OS "
                        "threads takes minutes on two cores: fibers run it";
      fake = test::fakeDriver(0, blockThreadsOf(GetParam()));
      driver = fake.get();
    }
    context = std::make_unique<CudaContext>(*driver, 0);
    host = std::make_unique<GlobalSystem>(scene.layout, scene.maps(0, 3));
    host->setDynamic(scene.maps(3, 4));
    gpu = std::make_unique<GpuSystem>(*context, *host);
  }

  /// Assembles every energy on both systems.
  void assemble() {
    host->setZero();
    gpu->setZero();
    for (std::size_t e = 0; e < scene.energies.size(); ++e) {
      const Energy &energy = scene.energies[e];
      host->add(e, energy.gradients.data(), energy.hessians.data());
      DeviceBuffer g = deviceCopy(*context, energy.gradients);
      DeviceBuffer h = deviceCopy(*context, energy.hessians);
      gpu->add(e, g.pointer(), h.pointer());
    }
  }

  /// Solves on both and compares.
  void expectSameSolve(const PcgOptions &options, int checkEvery = 8) {
    ThreadPool pool(1);
    std::vector<double> expected(host->size());
    PcgResult cpu = solvePcg(host->hessianParts(), host->gradient().data(),
                             expected.data(), options, pool);
    DeviceBuffer x(*context, host->size() * sizeof(double));
    PcgResult result = gpu->solve(x.pointer(), options, checkEvery);
    EXPECT_EQ(result.converged, cpu.converged);
    EXPECT_EQ(result.levels, cpu.levels);
    EXPECT_NEAR(double(result.iterations), double(cpu.iterations), 1.0);
    if (cpu.converged)
      // Near convergence the last residual is mostly rounding.
      EXPECT_LE(result.relativeResidual, options.relativeTolerance);
    else if (std::isnan(cpu.relativeResidual))
      EXPECT_TRUE(std::isnan(result.relativeResidual));
    else
      EXPECT_NEAR(result.relativeResidual, cpu.relativeResidual,
                  1e-6 * cpu.relativeResidual + 1e-300);
    if (cpu.iterations == result.iterations || cpu.converged)
      expectClose(download(x), expected, 1e-9, "PCG solution");
  }

  Scene scene;
  std::unique_ptr<CudaDriver> fake;
  CudaDriver *driver = nullptr;
  std::unique_ptr<CudaContext> context;
  std::unique_ptr<GlobalSystem> host;
  std::unique_ptr<GpuSystem> gpu;
};

TEST_P(GpuSystemTest, AssemblesLikeTheCpu) {
  assemble();
  expectClose(gpu->gradient(), host->gradient(), 1e-15, "gradient");
  expectClose(gpu->hessianValues(0), host->staticHessian().values(), 1e-14,
              "static Hessian");
  expectClose(gpu->hessianValues(1), host->dynamicHessian().values(), 1e-14,
              "dynamic Hessian");
  std::size_t stored = host->staticHessian().numStoredBlocks() +
                       host->dynamicHessian().numStoredBlocks();
  EXPECT_EQ(gpu->storedBlocks(), stored);
  EXPECT_EQ(gpu->multiplyBytes(),
            8 * (2 * host->size() + host->staticHessian().values().size() +
                 host->dynamicHessian().values().size()) +
                4 * 2 * stored);
  // The scene meets specialised and generic SpMV shapes.
  std::vector<std::pair<std::int64_t, std::int64_t>> shapes;
  for (const BlockGroup &group : host->staticHessian().groups())
    shapes.emplace_back(group.rows, group.cols);
  for (auto shape : std::vector<std::pair<std::int64_t, std::int64_t>>{
           {3, 3}, {3, 9}, {9, 9}, {3, 12}, {12, 2}, {2, 2}, {12, 12}})
    EXPECT_NE(std::find(shapes.begin(), shapes.end(), shape), shapes.end())
        << shape.first << "x" << shape.second;
}

TEST_P(GpuSystemTest, MultipliesLikeTheCpu) {
  assemble();
  std::normal_distribution<double> normal;
  std::vector<double> x(host->size()), expected(host->size());
  for (double &v : x)
    v = normal(scene.rng);
  ThreadPool pool(1);
  host->multiply(x.data(), expected.data(), pool);
  DeviceBuffer dx = deviceCopy(*context, x);
  DeviceBuffer dy(*context, x.size() * sizeof(double));
  gpu->multiply(dx.pointer(), dy.pointer());
  expectClose(download(dy), expected, 1e-13, "H x");
}

TEST_P(GpuSystemTest, SolvesLikeTheCpu) {
  assemble();
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  expectSameSolve(options);
  // How often the host looks does not change the result.
  expectSameSolve(options, 1);
  expectSameSolve(options, 1000);
}

TEST_P(GpuSystemTest, SolvesWithFixedDofs) {
  assemble();
  std::vector<std::uint8_t> mask(host->size(), 0);
  std::bernoulli_distribution pick(0.1);
  for (auto &m : mask)
    m = pick(scene.rng);
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  options.fixedDofs = &mask;
  expectSameSolve(options);
}

TEST_P(GpuSystemTest, StopsLikeTheCpu) {
  assemble();
  PcgOptions options;
  options.maxIterations = 5;
  expectSameSolve(options);
  options.maxIterations = 0;
  expectSameSolve(options);
}

TEST_P(GpuSystemTest, StopsByTheEnergyNormLikeTheCpu) {
  assemble();
  PcgOptions options;
  options.relativeTolerance = 1e-6;
  options.stopping = PcgStopping::EnergyNorm;
  expectSameSolve(options);
  ThreadPool pool(1);
  std::vector<double> expected(host->size());
  PcgResult cpu = solvePcg(host->hessianParts(), host->gradient().data(),
                           expected.data(), options, pool);
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgResult gpuResult = gpu->solve(x.pointer(), options);
  EXPECT_TRUE(gpuResult.converged);
  EXPECT_LE(gpuResult.energyError, options.relativeTolerance);
  EXPECT_NEAR(gpuResult.energyError, cpu.energyError, 1e-6 * cpu.energyError);
  options.energyDelay = 65;
  EXPECT_THROW(gpu->solve(x.pointer(), options), std::invalid_argument);
}

TEST_P(GpuSystemTest, StopsByThePreconditionedResidualLikeTheCpu) {
  assemble();
  PcgOptions options;
  options.relativeTolerance = 1e-3;
  options.stopping = PcgStopping::Preconditioned;
  expectSameSolve(options, 1);
  ThreadPool pool(1);
  std::vector<double> expected(host->size());
  PcgResult cpu = solvePcg(host->hessianParts(), host->gradient().data(),
                           expected.data(), options, pool);
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgResult gpuResult = gpu->solve(x.pointer(), options, 1);
  EXPECT_TRUE(gpuResult.converged);
  EXPECT_LE(gpuResult.preconditionedResidual, options.relativeTolerance);
  EXPECT_NEAR(gpuResult.preconditionedResidual, cpu.preconditionedResidual,
              1e-6 * cpu.preconditionedResidual);
}

TEST_P(GpuSystemTest, RestartsFromTheRecomputedResidualLikeTheCpu) {
  // A tolerance below round-off: the updated residual meets it, the
  // recomputed one cannot; both restart from the recomputed residual
  // twice, then say so.
  assemble();
  PcgOptions options;
  options.relativeTolerance = 1e-22;
  options.maxIterations = 100000;
  ThreadPool pool(1);
  std::vector<double> expected(host->size());
  PcgResult cpu = solvePcg(host->hessianParts(), host->gradient().data(),
                           expected.data(), options, pool);
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgResult result = gpu->solve(x.pointer(), options);
  ASSERT_EQ(cpu.stop, PcgStop::RoundOff);
  EXPECT_EQ(result.stop, PcgStop::RoundOff);
  EXPECT_FALSE(result.converged);
  EXPECT_GE(result.residualReplacements, 2);
  EXPECT_LT(result.relativeResidual, 1e-10);
  EXPECT_GT(result.relativeResidual, options.relativeTolerance);
  expectClose(download(x), expected, 1e-9, "PCG solution");
}

TEST_P(GpuSystemTest, ReportsBreakdownAndNonFiniteInput) {
  // A negative definite Hessian: CG breaks down on its first step.
  for (Energy &energy : scene.energies)
    scene.fill(energy, -1.0);
  assemble();
  expectSameSolve(PcgOptions{});
  // A NaN in one local Hessian.
  scene.energies[1].hessians[17] = std::nan("");
  assemble();
  expectSameSolve(PcgOptions{});
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgResult result = gpu->solve(x.pointer(), PcgOptions{});
  EXPECT_FALSE(result.converged);
  EXPECT_EQ(result.iterations, 0);
  for (double v : download(x))
    ASSERT_EQ(v, 0.0);
}

TEST_P(GpuSystemTest, ZeroRightHandSideIsSolvedAtOnce) {
  for (Energy &energy : scene.energies)
    std::fill(energy.gradients.begin(), energy.gradients.end(), 0.0);
  assemble();
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgResult result = gpu->solve(x.pointer(), PcgOptions{});
  EXPECT_TRUE(result.converged);
  EXPECT_EQ(result.iterations, 0);
  EXPECT_EQ(result.relativeResidual, 0.0);
}

TEST_P(GpuSystemTest, AssemblesFactoredHessians) {
  // Energy 2 (17 parameters) as J^T P J with a 5 x 17 map.
  const Energy &energy = scene.energies[2];
  const std::int64_t m = 5, n = energy.n;
  std::normal_distribution<double> normal;
  std::vector<double> maps(energy.count * m * n), inner(energy.count * m * m);
  for (double &v : maps)
    v = normal(scene.rng);
  for (std::int64_t i = 0; i < energy.count; ++i)
    for (std::int64_t r = 0; r < m; ++r)
      for (std::int64_t c = 0; c <= r; ++c)
        inner[(i * m + r) * m + c] = inner[(i * m + c) * m + r] =
            normal(scene.rng);
  host->setZero();
  gpu->setZero();
  host->addFactored(2, energy.gradients.data(), maps.data(), inner.data(), m);
  DeviceBuffer g = deviceCopy(*context, energy.gradients);
  DeviceBuffer j = deviceCopy(*context, maps);
  DeviceBuffer p = deviceCopy(*context, inner);
  gpu->addFactored(2, g.pointer(), j.pointer(), p.pointer(), m);
  expectClose(gpu->hessianValues(0), host->staticHessian().values(), 1e-13,
              "factored Hessian");
  // The same maps stored column-major, as generated kernels write them.
  std::vector<double> columnMajor(maps.size());
  for (std::int64_t i = 0; i < energy.count; ++i)
    for (std::int64_t r = 0; r < m; ++r)
      for (std::int64_t c = 0; c < n; ++c)
        columnMajor[(i * n + c) * m + r] = maps[(i * m + r) * n + c];
  DeviceBuffer jc = deviceCopy(*context, columnMajor);
  gpu->setZero();
  gpu->addFactored(2, g.pointer(), jc.pointer(), p.pointer(), m, true);
  expectClose(gpu->hessianValues(0), host->staticHessian().values(), 1e-13,
              "factored Hessian, column-major maps");
  EXPECT_THROW(gpu->addFactored(2, g.pointer(), j.pointer(), p.pointer(), 65),
               std::invalid_argument);
}

TEST_P(GpuSystemTest, FollowsANewDynamicPart) {
  // Fewer pairs than before: the buffers are reused (the stand-in driver
  // counts allocations).
  void *fake = GetParam() == Driver::ThisMachine
                   ? nullptr
                   : dlopen(test::fakeCudaPath(), RTLD_NOW | RTLD_LOCAL);
  auto allocations =
      fake ? reinterpret_cast<int (*)()>(dlsym(fake, "fakeCudaAllocations"))
           : nullptr;
  int before = allocations ? allocations() : 0;
  scene.energies[3] = scene.randomPairs(90);
  host->setDynamic(scene.maps(3, 4));
  gpu->updateDynamic(*host);
  if (allocations) {
    EXPECT_EQ(allocations(), before);
  }
  if (fake)
    dlclose(fake);
  assemble();
  expectClose(gpu->hessianValues(1), host->dynamicHessian().values(), 1e-14,
              "new dynamic Hessian");
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  expectSameSolve(options);
}

/// Options of a multilevel solve with levels small enough that the scene
/// has three of them.
PcgOptions multilevelOptions() {
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  options.preconditioner = PcgPreconditioner::Multilevel;
  options.multilevel.coarsestDofs = 60;
  return options;
}

TEST_P(GpuSystemTest, MultilevelSolvesLikeTheCpu) {
  assemble();
  PcgOptions options = multilevelOptions();
  Multilevel levels(host->hessianParts(), options.multilevel);
  ASSERT_GE(levels.numLevels(), 3u);
  expectSameSolve(options);
  // Again on the same levels, and with a dense coarsest level only.
  expectSameSolve(options, 1);
  options.multilevel.coarsestDofs = 2000;
  expectSameSolve(options);
  // The V-cycle through every level, too.
  PcgOptions vCycle = multilevelOptions();
  vCycle.multilevel.additiveFine = false;
  expectSameSolve(vCycle);
  // Fewer iterations than block-Jacobi (the V-cycle; on this small scene
  // the additive fine level takes about as many).
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgOptions jacobi;
  jacobi.relativeTolerance = 1e-12;
  EXPECT_LT(gpu->solve(x.pointer(), vCycle).iterations,
            gpu->solve(x.pointer(), jacobi).iterations);
}

TEST_P(GpuSystemTest, MultilevelSolvesWithFixedDofs) {
  assemble();
  std::vector<std::uint8_t> mask(host->size(), 0);
  std::bernoulli_distribution pick(0.1);
  for (auto &m : mask)
    m = pick(scene.rng);
  // A whole aggregate's worth: the first 20 vertices.
  std::fill(mask.begin(), mask.begin() + 60, 1);
  PcgOptions options = multilevelOptions();
  options.fixedDofs = &mask;
  expectSameSolve(options);
}

TEST_P(GpuSystemTest, MultilevelFollowsANewDynamicPart) {
  assemble();
  PcgOptions options = multilevelOptions();
  expectSameSolve(options);
  scene.energies[3] = scene.randomPairs(90);
  host->setDynamic(scene.maps(3, 4));
  gpu->updateDynamic(*host);
  assemble();
  expectSameSolve(options);
}

TEST_P(GpuSystemTest, HandlesEmptyEnergiesAndParts) {
  // No dynamic energy, and a static energy without instances.
  scene.energies[3] = scene.randomPairs(0);
  host->setDynamic({});
  gpu->updateDynamic(*host);
  Energy none = scene.randomPairs(0);
  std::vector<DofMap> maps = scene.maps(0, 3);
  maps.push_back({0, 6, none.dofs.data()});
  GlobalSystem withEmpty(scene.layout, maps);
  GpuSystem mirror(*context, withEmpty);
  ThreadPool pool(1);
  withEmpty.setZero();
  mirror.setZero();
  for (std::size_t e = 0; e < 3; ++e) {
    const Energy &energy = scene.energies[e];
    withEmpty.add(e, energy.gradients.data(), energy.hessians.data());
    DeviceBuffer g = deviceCopy(*context, energy.gradients);
    DeviceBuffer h = deviceCopy(*context, energy.hessians);
    mirror.add(e, g.pointer(), h.pointer());
  }
  DeviceBuffer nothing(*context, 0);
  mirror.add(3, nothing.pointer(), nothing.pointer());
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  std::vector<double> expected(withEmpty.size());
  PcgResult cpu =
      solvePcg(withEmpty.hessianParts(), withEmpty.gradient().data(),
               expected.data(), options, pool);
  DeviceBuffer x(*context, withEmpty.size() * sizeof(double));
  PcgResult result = mirror.solve(x.pointer(), options);
  EXPECT_TRUE(cpu.converged);
  EXPECT_TRUE(result.converged);
  expectClose(download(x), expected, 1e-9, "solution without dynamic part");
  EXPECT_TRUE(mirror.hessianValues(1).empty());
}

TEST_P(GpuSystemTest, RejectsMisuse) {
  DeviceBuffer x(*context, host->size() * sizeof(double));
  EXPECT_THROW(gpu->add(4, x.pointer(), x.pointer()), std::out_of_range);
  PcgOptions options;
  options.maxIterations = -1;
  EXPECT_THROW(gpu->solve(x.pointer(), options), std::invalid_argument);
  std::vector<std::uint8_t> shortMask(3, 0);
  options = PcgOptions{};
  options.fixedDofs = &shortMask;
  EXPECT_THROW(gpu->solve(x.pointer(), options), std::invalid_argument);
  EXPECT_THROW(gpu->solve(x.pointer(), PcgOptions{}, 0), std::invalid_argument);
  EXPECT_THROW(gpu->hessianValues(2), std::out_of_range);
  GlobalSystem other(BlockLayout::fromSizes({3}), {});
  EXPECT_THROW(gpu->updateDynamic(other), std::invalid_argument);
}

INSTANTIATE_TEST_SUITE_P(Drivers, GpuSystemTest,
                         ::testing::Values(Driver::StandIn,
                                           Driver::StandInFibers,
                                           Driver::StandInOsThreads,
                                           Driver::ThisMachine),
                         driverName);

/// The stand-in's own fault injection: on both stand-ins, not a device.
class StandInBarrierTest : public GpuSystemTest {};

TEST_P(StandInBarrierTest, AMissingBarrierShowsWhereThreadsRunAsThreads) {
  // Every thread of yasps_dot skips the first barrier of its block sum:
  // thread 0 adds v[64] before thread 64 has written it. Phase by phase the
  // stand-in cannot see that; with its threads as fibers the dot products,
  // and so the solve, go wrong. (On a GPU the outcome would depend on the
  // warps' timing.) Under ThreadSanitizer the fibers' read is also a data
  // race, which it reports: scripts/tsan.sh runs this test so and requires
  // the report.
  assemble();
  PcgOptions options;
  options.relativeTolerance = 1e-10;
  ThreadPool pool(1);
  std::vector<double> expected(host->size());
  PcgResult cpu = solvePcg(host->hessianParts(), host->gradient().data(),
                           expected.data(), options, pool);
  auto skipSync =
      test::fakeCudaFunction<void(const char *, int)>("fakeCudaSkipSync");
  skipSync("yasps_dot", 0);
  DeviceBuffer x(*context, host->size() * sizeof(double));
  PcgResult result = gpu->solve(x.pointer(), options);
  skipSync(nullptr, -1);
  std::vector<double> solution = download(x);
  double error = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < solution.size(); ++i) {
    error = std::max(error, std::fabs(solution[i] - expected[i]));
    scale = std::max(scale, std::fabs(expected[i]));
  }
  const bool wrong = !(error <= 1e-6 * scale) ||
                     result.converged != cpu.converged ||
                     std::abs(result.iterations - cpu.iterations) > 1;
  EXPECT_EQ(wrong, GetParam() == Driver::StandInFibers)
      << "error " << error << " of " << scale << ", iterations "
      << result.iterations << " against " << cpu.iterations;
  // With the barrier back, the solve is the CPU's again.
  expectSameSolve(options);
}

INSTANTIATE_TEST_SUITE_P(StandIns, StandInBarrierTest,
                         ::testing::Values(Driver::StandIn,
                                           Driver::StandInFibers),
                         driverName);

TEST(GpuSolverImages, HoldEveryKernelForSm80AndSm90) {
  const std::vector<GpuImage> &images = gpuSolverImages();
  if (images.empty())
    GTEST_SKIP() << "built without nvcc: no GPU solver kernels";
  for (const char *chip : {"sm_80", "sm_90"}) {
    const GpuImage &image = selectGpuImage(images, chip);
    EXPECT_EQ(image.format, "cubin");
    EXPECT_EQ(image.bytes->compare(0, 4,
                                   "\x7f"
                                   "ELF"),
              0);
    for (const std::string &name : gpuSolverKernelNames())
      EXPECT_NE(image.bytes->find(name), std::string::npos) << chip << name;
  }
  // Newer chips get PTX.
  EXPECT_EQ(selectGpuImage(images, "sm_100").format, "ptx");
}

} // namespace
