//===- GlobalSystemTest.cpp - tests of Newton system assembly -------------===//

#include "yasps/Runtime/Assembly/GlobalSystem.h"
#include "yasps/Runtime/Assembly/SlotFactors.h"
#include "yasps/Runtime/Sparse/PcgSolver.h"
#include "yasps/Runtime/Support/ThreadPool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace yasps::runtime;

namespace {

/// Two energies over 5 blocks of 3 DoFs and one of 9: an "edge" energy on
/// pairs of vertex blocks and a "body" energy mixing a vertex block with the
/// 9-DoF block, one parameter of it padding (-1).
struct Scene {
  BlockLayout layout{{0, 3, 6, 9, 12, 15, 24}};
  std::vector<std::int64_t> edgeDofs, bodyDofs;
  int64_t edgeCount = 4, bodyCount = 2, edgeN = 6, bodyN = 13;

  Scene() {
    int pairs[4][2] = {{0, 1}, {1, 2}, {3, 1}, {4, 0}};
    for (auto &p : pairs)
      for (int v : p)
        for (int e = 0; e < 3; ++e)
          edgeDofs.push_back(3 * v + e);
    for (int i = 0; i < 2; ++i) {
      for (int e = 0; e < 3; ++e)
        bodyDofs.push_back(3 * (i + 2) + e);
      for (int e = 0; e < 9; ++e)
        bodyDofs.push_back(15 + e);
      bodyDofs.push_back(-1); // padding
    }
  }
  std::vector<DofMap> maps() const {
    return {{edgeCount, edgeN, edgeDofs.data()},
            {bodyCount, bodyN, bodyDofs.data()}};
  }
};

std::vector<double> randomSpd(std::mt19937 &rng, int n, int count) {
  std::normal_distribution<double> normal;
  std::vector<double> out(count * n * n);
  for (int i = 0; i < count; ++i) {
    std::vector<double> a(n * n);
    for (double &v : a)
      v = normal(rng);
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c) {
        double s = r == c ? 1.0 : 0.0;
        for (int k = 0; k < n; ++k)
          s += a[r * n + k] * a[c * n + k];
        out[i * n * n + r * n + c] = s;
      }
  }
  return out;
}

} // namespace

TEST(GlobalSystem, AssemblesLikeADenseReference) {
  Scene scene;
  GlobalSystem system(scene.layout, scene.maps());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  auto he = randomSpd(rng, scene.edgeN, scene.edgeCount);
  auto hb = randomSpd(rng, scene.bodyN, scene.bodyCount);
  std::vector<double> ge(scene.edgeCount * scene.edgeN),
      gb(scene.bodyCount * scene.bodyN);
  for (double &v : ge)
    v = normal(rng);
  for (double &v : gb)
    v = normal(rng);
  system.setZero();
  system.add(0, ge.data(), he.data());
  system.add(1, gb.data(), hb.data());

  const int64_t n = 24;
  std::vector<double> dense(n * n, 0.0), grad(n, 0.0);
  auto scatter = [&](const std::vector<std::int64_t> &dofs, int64_t count,
                     int64_t m, const std::vector<double> &g,
                     const std::vector<double> &h) {
    for (int64_t i = 0; i < count; ++i)
      for (int64_t a = 0; a < m; ++a) {
        std::int64_t da = dofs[i * m + a];
        if (da < 0)
          continue;
        grad[da] += g[i * m + a];
        for (int64_t b = 0; b < m; ++b) {
          std::int64_t db = dofs[i * m + b];
          if (db >= 0)
            dense[da * n + db] += h[i * m * m + a * m + b];
        }
      }
  };
  scatter(scene.edgeDofs, scene.edgeCount, scene.edgeN, ge, he);
  scatter(scene.bodyDofs, scene.bodyCount, scene.bodyN, gb, hb);
  std::vector<double> assembled = system.toDense();
  for (int64_t k = 0; k < n * n; ++k)
    EXPECT_NEAR(assembled[k], dense[k], 1e-12) << "entry " << k;
  for (int64_t k = 0; k < n; ++k)
    EXPECT_NEAR(system.gradient()[k], grad[k], 1e-12);

  // Re-assembly after setZero gives the same system.
  system.setZero();
  system.add(0, ge.data(), he.data());
  system.add(1, gb.data(), hb.data());
  EXPECT_EQ(system.toDense(), assembled);

  // The PCG solution satisfies H x = g.
  std::vector<double> x(n, 0.0);
  PcgOptions options;
  options.relativeTolerance = 1e-12;
  ThreadPool pool(2);
  PcgResult result = PcgSolver().solve(
      system.hessianParts(), system.gradient().data(), x.data(), options, pool);
  EXPECT_TRUE(result.converged);
  for (int64_t r = 0; r < n; ++r) {
    double s = 0;
    for (int64_t c = 0; c < n; ++c)
      s += dense[r * n + c] * x[c];
    EXPECT_NEAR(s, grad[r], 1e-9);
  }
}

TEST(GlobalSystem, AddsToListedInstancesAsAFullAddWithZerosElsewhere) {
  // Instances 1 and 3 of the edges, and body 0 (with its padding): the
  // same system as adding every instance's Hessian with zeros for the
  // others, and the gradient untouched.
  Scene scene;
  std::mt19937 rng(8);
  auto he = randomSpd(rng, scene.edgeN, scene.edgeCount);
  auto hb = randomSpd(rng, scene.bodyN, scene.bodyCount);
  std::vector<double> ge(scene.edgeCount * scene.edgeN, 0.5),
      gb(scene.bodyCount * scene.bodyN, -0.25);
  GlobalSystem listed(scene.layout, scene.maps()),
      full(scene.layout, scene.maps());
  for (GlobalSystem *system : {&listed, &full}) {
    system->setZero();
    system->add(0, ge.data(), he.data());
    system->add(1, gb.data(), hb.data());
  }
  const std::int64_t edges[2] = {1, 3}, bodies[1] = {0};
  const int64_t ne = scene.edgeN * scene.edgeN, nb = scene.bodyN * scene.bodyN;
  std::vector<double> edgeUpdate(he.begin() + ne, he.begin() + 2 * ne);
  edgeUpdate.insert(edgeUpdate.end(), he.begin() + 3 * ne, he.begin() + 4 * ne);
  listed.addToInstances(0, edges, 2, edgeUpdate.data());
  listed.addToInstances(1, bodies, 1, hb.data());
  std::vector<double> edgesFull(he.size(), 0.0), bodiesFull(hb.size(), 0.0);
  for (int64_t i : edges)
    std::copy(he.begin() + i * ne, he.begin() + (i + 1) * ne,
              edgesFull.begin() + i * ne);
  std::copy(hb.begin(), hb.begin() + nb, bodiesFull.begin());
  std::vector<double> noEdgeGradient(ge.size(), 0.0),
      noBodyGradient(gb.size(), 0.0);
  full.add(0, noEdgeGradient.data(), edgesFull.data());
  full.add(1, noBodyGradient.data(), bodiesFull.data());
  EXPECT_EQ(listed.toDense(), full.toDense());
  EXPECT_EQ(listed.gradient(), full.gradient());
  const std::int64_t outside[1] = {scene.edgeCount};
  EXPECT_THROW(listed.addToInstances(0, outside, 1, he.data()),
               std::out_of_range);
}

TEST(GlobalSystem, AssemblesF32LocalDerivativesAsWidened) {
  // f32 local derivatives are widened exactly and summed in f64 in the
  // same order: the system is, to the bit, that of the widened values.
  Scene scene;
  std::mt19937 rng(4);
  auto he = randomSpd(rng, scene.edgeN, scene.edgeCount);
  auto hb = randomSpd(rng, scene.bodyN, scene.bodyCount);
  std::vector<double> ge(scene.edgeCount * scene.edgeN, 0.5),
      gb(scene.bodyCount * scene.bodyN, -0.25);
  auto narrow = [](const std::vector<double> &v) {
    return std::vector<float>(v.begin(), v.end());
  };
  std::vector<float> ge32 = narrow(ge), gb32 = narrow(gb), he32 = narrow(he),
                     hb32 = narrow(hb);
  auto widen = [](const std::vector<float> &v) {
    return std::vector<double>(v.begin(), v.end());
  };
  GlobalSystem wide(scene.layout, scene.maps()),
      single(scene.layout, scene.maps());
  wide.setZero();
  wide.add(0, widen(ge32).data(), widen(he32).data());
  wide.add(1, widen(gb32).data(), widen(hb32).data());
  single.setZero();
  single.add(0, ge32.data(), he32.data());
  single.add(1, gb32.data(), hb32.data());
  EXPECT_EQ(single.toDense(), wide.toDense());
  EXPECT_EQ(single.gradient(), wide.gradient());
}

TEST(GlobalSystem, SingleProductsReadTheRoundedBlocks) {
  // With single products, multiply after finishAssembly is the product of
  // the matrix rounded to f32; an add() after it reads f64 values again.
  Scene scene;
  std::mt19937 rng(6);
  auto he = randomSpd(rng, scene.edgeN, scene.edgeCount);
  auto hb = randomSpd(rng, scene.bodyN, scene.bodyCount);
  std::vector<double> ge(scene.edgeCount * scene.edgeN, 1.0),
      gb(scene.bodyCount * scene.bodyN, 1.0);
  GlobalSystem system(scene.layout, scene.maps());
  system.setSingleProduct(true);
  system.setZero();
  system.add(0, ge.data(), he.data());
  system.add(1, gb.data(), hb.data());
  const std::size_t n = static_cast<std::size_t>(system.size());
  std::vector<double> x(n), exact(n), single(n);
  std::normal_distribution<double> normal;
  for (double &v : x)
    v = normal(rng);
  ThreadPool pool(1);
  system.multiply(x.data(), exact.data(), pool);
  system.finishAssembly();
  system.multiply(x.data(), single.data(), pool);
  std::vector<double> dense = system.toDense(), rounded(n, 0.0);
  for (std::size_t r = 0; r < n; ++r)
    for (std::size_t c = 0; c < n; ++c)
      rounded[r] +=
          static_cast<double>(static_cast<float>(dense[r * n + c])) * x[c];
  EXPECT_NE(single, exact);
  for (std::size_t r = 0; r < n; ++r)
    EXPECT_NEAR(single[r], rounded[r], 1e-12 * (1 + std::abs(rounded[r])));
  // A further add drops its part's copy.
  system.add(0, ge.data(), he.data());
  std::vector<double> again(n);
  system.multiply(x.data(), again.data(), pool);
  std::vector<double> twice = system.toDense(), want(n, 0.0);
  for (std::size_t r = 0; r < n; ++r)
    for (std::size_t c = 0; c < n; ++c)
      want[r] += twice[r * n + c] * x[c];
  for (std::size_t r = 0; r < n; ++r)
    EXPECT_NEAR(again[r], want[r], 1e-9 * (1 + std::abs(want[r])));
}

TEST(GlobalSystem, RejectsDofsOutsideTheLayout) {
  BlockLayout layout{{0, 3}};
  std::vector<std::int64_t> dofs = {0, 1, 3};
  EXPECT_THROW(GlobalSystem(layout, {{1, 3, dofs.data()}}),
               std::invalid_argument);
  GlobalSystem ok(layout, {});
  EXPECT_THROW(ok.add(0, static_cast<const double *>(nullptr), nullptr),
               std::out_of_range);
}

TEST(GlobalSystem, RebuildsOnlyTheDynamicPart) {
  // The edge energy is static; the body energy is dynamic and changes its
  // number of instances between assemblies (like collision pairs).
  Scene scene;
  std::vector<DofMap> maps = scene.maps();
  GlobalSystem system(scene.layout, {maps[0]});
  const BlockSparseMatrix *staticMatrix = &system.staticHessian();
  std::size_t staticBlocks = staticMatrix->numStoredBlocks();
  EXPECT_EQ(system.numEnergies(), 1u);

  std::mt19937 rng(5);
  auto he = randomSpd(rng, scene.edgeN, scene.edgeCount);
  auto hb = randomSpd(rng, scene.bodyN, scene.bodyCount);
  std::vector<double> ge(scene.edgeCount * scene.edgeN, 1.0),
      gb(scene.bodyCount * scene.bodyN, -2.0);
  ThreadPool pool(2);
  for (std::int64_t bodies : {2, 0, 1}) {
    system.setDynamic({{bodies, scene.bodyN, scene.bodyDofs.data()}});
    EXPECT_EQ(system.numEnergies(), 2u);
    EXPECT_EQ(&system.staticHessian(), staticMatrix);
    EXPECT_EQ(system.staticHessian().numStoredBlocks(), staticBlocks);
    system.setZero();
    system.add(0, ge.data(), he.data());
    system.add(1, gb.data(), hb.data());

    // The same energies, all static, as the reference.
    GlobalSystem whole(scene.layout,
                       {maps[0], {bodies, scene.bodyN, scene.bodyDofs.data()}});
    whole.setZero();
    whole.add(0, ge.data(), he.data());
    whole.add(1, gb.data(), hb.data());
    EXPECT_EQ(system.toDense(), whole.toDense()) << bodies << " bodies";
    EXPECT_EQ(system.gradient(), whole.gradient());

    std::vector<double> x(24), y(24), yWhole(24);
    for (int i = 0; i < 24; ++i)
      x[i] = std::sin(1.0 + i);
    system.multiply(x.data(), y.data(), pool);
    whole.multiply(x.data(), yWhole.data(), pool);
    for (int i = 0; i < 24; ++i)
      EXPECT_NEAR(y[i], yWhole[i], 1e-12);

    // PCG on the sum matches PCG on the single matrix.
    PcgOptions options;
    options.relativeTolerance = 1e-13;
    std::vector<double> a(24), b(24);
    EXPECT_TRUE(solvePcg(system.hessianParts(), system.gradient().data(),
                         a.data(), options, pool)
                    .converged);
    EXPECT_TRUE(solvePcg(whole.hessianParts(), whole.gradient().data(),
                         b.data(), options, pool)
                    .converged);
    for (int i = 0; i < 24; ++i)
      EXPECT_NEAR(a[i], b[i], 1e-9 * (1 + std::abs(b[i])));
  }
  EXPECT_THROW(system.add(2, static_cast<const double *>(nullptr), nullptr),
               std::out_of_range);
}

namespace {
/// A scene for threaded assembly: 400 blocks, mostly vertices with a
/// 12-DoF (affine) block every 100, and energies down every path of
/// addInstance at random blocks, so that many instances straddle the
/// threads' row ranges.
struct MixedScene {
  BlockLayout layout{{0}};
  std::vector<std::int64_t> vertices, affines;
  std::vector<std::int64_t> tetDofs, bodyDofs, mergedDofs, pairDofs;
  const std::int64_t tets = 3000, bodies = 800, merged = 600, pairs = 700;
  std::vector<double> tetG, tetH, bodyG, bodyJ, bodyP, mergedG, mergedH, slotG,
      slotP, pairG, pairH;
  std::vector<double> identity = std::vector<double>(9, 0.0);
  std::vector<std::int64_t> sources;

  MixedScene() {
    for (std::int64_t b = 0; b < 400; ++b) {
      std::int64_t size = b % 100 == 50 ? 12 : 3;
      (size == 3 ? vertices : affines).push_back(b);
      layout.blockOffset.push_back(layout.blockOffset.back() + size);
    }
    std::mt19937 rng(9);
    std::uniform_int_distribution<std::size_t> vertex(0, vertices.size() - 1),
        affine(0, affines.size() - 1);
    auto dofsOf = [&](std::int64_t block, std::int64_t k) {
      return layout.blockOffset[block] + k;
    };
    // Tets: four distinct vertices (the 3x3 fast path).
    for (std::int64_t i = 0; i < tets; ++i) {
      std::vector<std::int64_t> picked;
      while (picked.size() < 4) {
        std::int64_t v = vertices[vertex(rng)];
        if (std::find(picked.begin(), picked.end(), v) == picked.end())
          picked.push_back(v);
      }
      for (std::int64_t v : picked)
        for (int e = 0; e < 3; ++e)
          tetDofs.push_back(dofsOf(v, e));
    }
    // A vertex and 9 of an affine block's DoFs, then padding (the gathered
    // path), assembled from factors.
    for (std::int64_t i = 0; i < bodies; ++i) {
      std::int64_t v = vertices[vertex(rng)], a = affines[affine(rng)];
      for (int e = 0; e < 3; ++e)
        bodyDofs.push_back(dofsOf(v, e));
      for (int e = 0; e < 9; ++e)
        bodyDofs.push_back(dofsOf(a, e));
      bodyDofs.push_back(-1);
    }
    // One vertex twice, one DoF of another, padding (the merged path).
    for (std::int64_t i = 0; i < merged; ++i) {
      std::int64_t v = vertices[vertex(rng)], w = vertices[vertex(rng)];
      for (int k = 0; k < 2; ++k)
        for (int e = 0; e < 3; ++e)
          mergedDofs.push_back(dofsOf(v, e));
      mergedDofs.push_back(dofsOf(w, 1));
      mergedDofs.push_back(-1);
    }
    // Pairs of vertices, for the dynamic part.
    for (std::int64_t i = 0; i < pairs; ++i)
      for (std::int64_t v : {vertices[vertex(rng)], vertices[vertex(rng)]})
        for (int e = 0; e < 3; ++e)
          pairDofs.push_back(dofsOf(v, e));
    std::normal_distribution<double> normal;
    auto random = [&](std::size_t n) {
      std::vector<double> out(n);
      for (double &v : out)
        v = normal(rng);
      return out;
    };
    tetG = random(tets * 12);
    tetH = randomSpd(rng, 12, static_cast<int>(tets));
    bodyG = random(bodies * 13);
    bodyJ = random(bodies * 4 * 13);
    bodyP = randomSpd(rng, 4, static_cast<int>(bodies));
    mergedG = random(merged * 8);
    mergedH = randomSpd(rng, 8, static_cast<int>(merged));
    // The tets again through slot factors: four identity slots.
    slotG = random(tets * 12);
    slotP = randomSpd(rng, 12, static_cast<int>(tets));
    for (int e = 0; e < 3; ++e)
      identity[e * 3 + e] = 1.0;
    sources.assign(tets * 4 * 2, 0);
    pairG = random(pairs * 6);
    pairH = randomSpd(rng, 6, static_cast<int>(pairs));
  }

  std::vector<DofMap> staticMaps() const {
    return {{tets, 12, tetDofs.data()},
            {bodies, 13, bodyDofs.data()},
            {merged, 8, mergedDofs.data()},
            {tets, 12, tetDofs.data()}};
  }

  /// The system assembled with `pool` (none: in order, on this thread).
  GlobalSystem assemble(ThreadPool *pool) const {
    GlobalSystem system(layout, staticMaps());
    system.setDynamic({{pairs, 6, pairDofs.data()}});
    system.setZero();
    system.add(0, tetG.data(), tetH.data(), pool);
    system.addFactored(1, bodyG.data(), bodyJ.data(), bodyP.data(), 4, pool);
    system.add(2, mergedG.data(), mergedH.data(), pool);
    SlotFactors factors;
    factors.numInner = 12;
    factors.tables = {{identity.data(), 1, 3, 3}};
    for (std::int64_t s = 0; s < 4; ++s)
      factors.slots.push_back({s, 4, 3 * s});
    factors.sources = sources.data();
    system.addSlotFactored(3, slotG.data(), slotP.data(), factors, pool);
    system.add(4, pairG.data(), pairH.data(), pool);
    return system;
  }
};
} // namespace

TEST(GlobalSystem, ThreadedAssemblyGivesTheSequentialBits) {
  // Each thread writes its own block rows and takes their entries from
  // every instance in order, so every entry is the same sum in the same
  // order as on one thread: equal to the last bit, on every path.
  MixedScene scene;
  GlobalSystem sequential = scene.assemble(nullptr);
  std::vector<double> want = sequential.toDense();
  double scale = 0.0;
  for (double v : want)
    scale = std::max(scale, std::abs(v));
  ASSERT_GT(scale, 0.0);
  for (unsigned threads : {2u, 3u, 5u}) {
    ThreadPool pool(threads);
    GlobalSystem threaded = scene.assemble(&pool);
    // The work really is split: one range per thread, for the tets'
    // energies and the pairs'.
    for (std::size_t energy : {0u, 3u, 4u})
      EXPECT_EQ(threaded.energyStructure(energy).splitRanges.size(),
                threads + 1)
          << "energy " << energy;
    EXPECT_EQ(threaded.staticHessian().values(),
              sequential.staticHessian().values())
        << threads << " threads";
    EXPECT_EQ(threaded.dynamicHessian().values(),
              sequential.dynamicHessian().values())
        << threads << " threads";
    EXPECT_EQ(threaded.gradient(), sequential.gradient())
        << threads << " threads";
  }
}

TEST(GlobalSystem, AssemblesFactoredHessians) {
  // The body energy's Hessians given as J^T P J with m = 4 inner variables
  // assemble like the explicit products.
  Scene scene;
  std::vector<DofMap> maps = scene.maps();
  const std::int64_t m = 4, n = scene.bodyN, count = scene.bodyCount;
  std::mt19937 rng(13);
  std::normal_distribution<double> normal;
  std::vector<double> j(count * m * n), g(count * n);
  for (double &v : j)
    v = normal(rng);
  for (double &v : g)
    v = normal(rng);
  auto p = randomSpd(rng, m, count);
  std::vector<double> h(count * n * n, 0.0);
  for (std::int64_t i = 0; i < count; ++i)
    for (std::int64_t a = 0; a < n; ++a)
      for (std::int64_t b = 0; b < n; ++b)
        for (std::int64_t k = 0; k < m; ++k)
          for (std::int64_t l = 0; l < m; ++l)
            h[(i * n + a) * n + b] += j[(i * m + k) * n + a] *
                                      p[(i * m + k) * m + l] *
                                      j[(i * m + l) * n + b];
  GlobalSystem explicitSystem(scene.layout, maps), factored(scene.layout, maps);
  explicitSystem.setZero();
  explicitSystem.add(1, g.data(), h.data());
  factored.setZero();
  ThreadPool pool(2);
  factored.addFactored(1, g.data(), j.data(), p.data(), m, &pool);
  std::vector<double> a = explicitSystem.toDense(), b = factored.toDense();
  for (std::size_t k = 0; k < a.size(); ++k)
    ASSERT_NEAR(a[k], b[k], 1e-10 * (1 + std::abs(a[k]))) << "entry " << k;
  EXPECT_EQ(explicitSystem.gradient(), factored.gradient());
  EXPECT_THROW(factored.addFactored(2, g.data(), j.data(), p.data(), m),
               std::out_of_range);
}

TEST(GlobalSystem, AssemblesSlotFactoredHessians) {
  // Pairs of a soft vertex (3 DoFs, identity Jacobian) or an affine body's
  // vertex (12 DoFs, a 3 x 12 Jacobian per vertex) in one UNION, slots
  // padded to 12: J taken from the tables gives what the padded
  // per-instance J (m = 6 inner variables, the join's entry e of slot s at
  // e * 2 + s) gives.
  BlockLayout layout{{0, 3, 6, 9, 21}};
  const std::int64_t m = 6, n = 24, count = 3;
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  std::vector<double> identity(9, 0.0), affine(2 * 3 * 12);
  for (int e = 0; e < 3; ++e)
    identity[e * 3 + e] = 1.0;
  for (double &v : affine)
    v = normal(rng);
  // (table, row) per slot: 0 = soft (identity), 1 = affine vertex.
  std::vector<std::int64_t> sources = {0,      0, 1, 1, /**/ 1, 0, 0, 0,
                                       /**/ 0, 0, 0, 0};
  int softOf[3][2] = {{0, -1}, {-1, 2}, {1, 0}};
  std::vector<std::int64_t> dofs(count * n, -1);
  std::vector<double> j(count * m * n, 0.0);
  for (std::int64_t i = 0; i < count; ++i)
    for (std::int64_t s = 0; s < 2; ++s) {
      bool soft = sources[(i * 2 + s) * 2] == 0;
      std::int64_t row = sources[(i * 2 + s) * 2 + 1];
      std::int64_t cols = soft ? 3 : 12;
      const double *t = soft ? identity.data() : &affine[row * 36];
      for (std::int64_t c = 0; c < cols; ++c) {
        dofs[i * n + 12 * s + c] = soft ? 3 * softOf[i][s] + c : 9 + c;
        for (std::int64_t e = 0; e < 3; ++e)
          j[(i * m + e * 2 + s) * n + 12 * s + c] = t[e * cols + c];
      }
    }
  std::vector<double> gInner(count * m), g(count * n, 0.0);
  for (double &v : gInner)
    v = normal(rng);
  for (std::int64_t i = 0; i < count; ++i)
    for (std::int64_t a = 0; a < n; ++a)
      for (std::int64_t k = 0; k < m; ++k)
        g[i * n + a] += j[(i * m + k) * n + a] * gInner[i * m + k];
  auto p = randomSpd(rng, m, count);
  std::vector<DofMap> maps = {{count, n, dofs.data()}};
  GlobalSystem padded(layout, maps), slotted(layout, maps);
  padded.setZero();
  padded.addFactored(0, g.data(), j.data(), p.data(), m);
  SlotFactors factors;
  factors.numInner = m;
  factors.tables = {{identity.data(), 1, 3, 3}, {affine.data(), 2, 3, 12}};
  factors.slots = {{0, 2, 0}, {1, 2, 12}};
  factors.sources = sources.data();
  slotted.setZero();
  ThreadPool pool(2);
  slotted.addSlotFactored(0, gInner.data(), p.data(), factors, &pool);
  std::vector<double> a = padded.toDense(), b = slotted.toDense();
  for (std::size_t k = 0; k < a.size(); ++k)
    ASSERT_NEAR(a[k], b[k], 1e-12 * (1 + std::abs(a[k]))) << "entry " << k;
  for (std::size_t k = 0; k < padded.gradient().size(); ++k)
    ASSERT_NEAR(padded.gradient()[k], slotted.gradient()[k], 1e-12);

  // A row outside its table, and a DoF that no slot's Jacobian covers.
  std::vector<std::int64_t> outside = sources;
  outside[3] = 2;
  factors.sources = outside.data();
  EXPECT_THROW(slotted.addSlotFactored(0, gInner.data(), p.data(), factors),
               std::invalid_argument);
  std::vector<std::int64_t> uncovered = sources;
  uncovered[2] = -1;
  factors.sources = uncovered.data();
  EXPECT_THROW(slotted.addSlotFactored(0, gInner.data(), p.data(), factors),
               std::invalid_argument);
}

TEST(GlobalSystem, MergesParametersOfOneDof) {
  // Two slots of one instance on the same vertex (a pair of an affine body
  // with itself): the parameters sharing a DoF are summed before they are
  // accumulated, and the system is the local one folded onto the DoFs.
  BlockLayout layout{{0, 3, 6}};
  std::vector<std::int64_t> dofs = {3, 4, 5, 3, 4, 5, 0, -1};
  const std::int64_t n = 8;
  std::vector<DofMap> maps = {{1, n, dofs.data()}};
  std::mt19937 rng(9);
  auto h = randomSpd(rng, n, 1);
  std::vector<double> g(n);
  std::normal_distribution<double> normal;
  for (double &v : g)
    v = normal(rng);
  GlobalSystem system(layout, maps);
  system.setZero();
  system.add(0, g.data(), h.data());
  std::vector<double> want(36, 0.0), wantGradient(6, 0.0);
  for (std::int64_t a = 0; a < n; ++a) {
    if (dofs[a] < 0)
      continue;
    wantGradient[dofs[a]] += g[a];
    for (std::int64_t b = 0; b < n; ++b)
      if (dofs[b] >= 0)
        want[dofs[a] * 6 + dofs[b]] += h[a * n + b];
  }
  std::vector<double> got = system.toDense();
  for (std::size_t k = 0; k < want.size(); ++k)
    ASSERT_NEAR(got[k], want[k], 1e-12 * (1 + std::abs(want[k]))) << k;
  for (std::size_t k = 0; k < wantGradient.size(); ++k)
    ASSERT_NEAR(system.gradient()[k], wantGradient[k], 1e-12);
}

TEST(GlobalSystem, SplitsEachEnergysOwnRowsEvenly) {
  // Two bodies of 1,000 vertices, an edge energy on each: the matrix's even
  // split would leave each energy to one thread; each energy's own ranges
  // give both threads half of its blocks, with the sequential bits.
  constexpr std::int64_t kVertices = 2000, kEdges = 999;
  BlockLayout layout =
      BlockLayout::fromSizes(std::vector<std::int64_t>(kVertices, 3));
  std::vector<std::int64_t> first, second;
  for (std::int64_t i = 0; i < kEdges; ++i)
    for (std::int64_t v : {i, i + 1})
      for (std::int64_t e = 0; e < 3; ++e) {
        first.push_back(3 * v + e);
        second.push_back(3 * (v + kVertices / 2) + e);
      }
  std::mt19937 rng(5);
  std::vector<double> g(kEdges * 6, 1.0);
  std::vector<double> h = randomSpd(rng, 6, kEdges);
  auto assemble = [&](ThreadPool *pool) {
    GlobalSystem system(
        layout, {{kEdges, 6, first.data()}, {kEdges, 6, second.data()}});
    system.setZero();
    system.add(0, g.data(), h.data(), pool);
    system.add(1, g.data(), h.data(), pool);
    return system;
  };
  GlobalSystem sequential = assemble(nullptr);
  ThreadPool pool(2);
  GlobalSystem threaded = assemble(&pool);
  EXPECT_EQ(threaded.staticHessian().values(),
            sequential.staticHessian().values());
  EXPECT_EQ(threaded.gradient(), sequential.gradient());
  for (std::size_t energy : {0u, 1u}) {
    const std::vector<std::int64_t> &ranges =
        threaded.energyStructure(energy).splitRanges;
    ASSERT_EQ(ranges.size(), 3u);
    const std::int64_t start = energy * kVertices / 2;
    // Its 1,000 vertices' blocks (1,998 block uses) cut in the middle.
    EXPECT_NEAR(static_cast<double>(ranges[1]),
                static_cast<double>(start + kVertices / 4), 1.0)
        << "energy " << energy;
  }
}
