//===- LocalCompressionTest.cpp - tests of local Hessian compression ------===//

#include "yasps/Runtime/Assembly/LocalCompression.h"

#include <gtest/gtest.h>

#include <random>

using namespace yasps::runtime;

namespace {
/// The n x n matrix that instance `i` adds to the global matrix of `size`
/// DoFs (duplicates summed, padding dropped), row-major.
std::vector<double> scattered(std::int64_t n, const std::int64_t *dofs,
                              const double *h, std::int64_t size) {
  std::vector<double> global(static_cast<std::size_t>(size * size), 0.0);
  for (std::int64_t a = 0; a < n; ++a)
    for (std::int64_t b = 0; b < n; ++b)
      if (dofs[a] >= 0 && dofs[b] >= 0)
        global[dofs[a] * size + dofs[b]] += h[a * n + b];
  return global;
}
} // namespace

TEST(LocalCompression, MergesRepeatedDofsAndDropsPadding) {
  // Four parameters: DoFs 5, padding, 5 again, 2 -> two compressed DoFs.
  const std::int64_t n = 4;
  std::vector<std::int64_t> dofs = {5, -1, 5, 2, /* second instance */ 0,
                                    1, 2,  3};
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> value(-1, 1);
  std::vector<double> h(2 * n * n);
  for (double &v : h)
    v = value(rng);
  EXPECT_EQ(compressedSize(n, dofs.data()), 2);
  EXPECT_EQ(compressedSize(n, dofs.data() + n), 4);

  std::vector<CompressedBatch> batches =
      compressLocalHessians(2, n, dofs.data(), h.data());
  ASSERT_EQ(batches.size(), 2u);
  EXPECT_EQ(batches[0].size, 2);
  EXPECT_EQ(batches[0].instances, std::vector<std::int64_t>{0});
  EXPECT_EQ(batches[1].size, 4);
  EXPECT_EQ(batches[1].instances, std::vector<std::int64_t>{1});
  // Compressed (0, 0) is DoF 5 with itself: the four entries of parameters
  // 0 and 2 summed.
  EXPECT_DOUBLE_EQ(batches[0].matrices[0], h[0] + h[2] + h[8] + h[10]);

  // Expanding the (unprojected) compressed matrices assembles to the same
  // global matrix as the originals.
  std::vector<double> out(2 * n * n, 7.0);
  for (const CompressedBatch &batch : batches)
    expandLocalHessians(2, n, dofs.data(), batch, batch.matrices.data(),
                        out.data());
  for (std::int64_t i = 0; i < 2; ++i) {
    auto want = scattered(n, &dofs[i * n], &h[i * n * n], 6);
    auto got = scattered(n, &dofs[i * n], &out[i * n * n], 6);
    for (std::size_t k = 0; k < want.size(); ++k)
      EXPECT_NEAR(got[k], want[k], 1e-14) << "instance " << i;
  }
  // Padding and repeated parameters get zeros.
  for (std::int64_t b = 0; b < n; ++b) {
    EXPECT_EQ(out[1 * n + b], 0.0);
    EXPECT_EQ(out[2 * n + b], 0.0);
  }
}

TEST(LocalCompression, RejectsABatchOfAnotherSize) {
  std::vector<std::int64_t> dofs = {0, 1, 0};
  std::vector<double> h(9, 1.0), out(9);
  CompressedBatch wrong{3, {0}, std::vector<double>(9, 0.0)};
  EXPECT_THROW(expandLocalHessians(1, 3, dofs.data(), wrong,
                                   wrong.matrices.data(), out.data()),
               std::invalid_argument);
}
