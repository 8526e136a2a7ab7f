//===- LocalCompression.cpp - compressing local Hessians ------------------===//

#include "yasps/Runtime/Assembly/LocalCompression.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

using namespace yasps::runtime;

namespace {
/// For each parameter of one instance, its compressed index (-1: none),
/// and for each compressed index the first parameter with that DoF.
struct Mapping {
  std::vector<std::int64_t> compressed;
  std::vector<std::int64_t> first;
};

Mapping mappingOf(std::int64_t n, const std::int64_t *dofs) {
  Mapping m;
  m.compressed.assign(static_cast<std::size_t>(n), -1);
  for (std::int64_t a = 0; a < n; ++a) {
    if (dofs[a] < 0)
      continue;
    std::int64_t same = -1;
    for (std::size_t c = 0; c < m.first.size(); ++c)
      if (dofs[m.first[c]] == dofs[a]) {
        same = static_cast<std::int64_t>(c);
        break;
      }
    if (same < 0) {
      same = static_cast<std::int64_t>(m.first.size());
      m.first.push_back(a);
    }
    m.compressed[a] = same;
  }
  return m;
}
} // namespace

std::int64_t yasps::runtime::compressedSize(std::int64_t n,
                                            const std::int64_t *dofs) {
  // Counted in place: this runs on every instance of every assembly.
  std::int64_t distinct = 0;
  for (std::int64_t a = 0; a < n; ++a) {
    if (dofs[a] < 0)
      continue;
    bool seen = false;
    for (std::int64_t b = 0; b < a && !seen; ++b)
      seen = dofs[b] == dofs[a];
    distinct += !seen;
  }
  return distinct;
}

std::vector<CompressedBatch>
yasps::runtime::compressLocalHessians(std::int64_t count, std::int64_t n,
                                      const std::int64_t *dofs,
                                      const double *hessians) {
  std::map<std::int64_t, CompressedBatch> bySize;
  for (std::int64_t i = 0; i < count; ++i) {
    Mapping m = mappingOf(n, dofs + i * n);
    std::int64_t k = static_cast<std::int64_t>(m.first.size());
    CompressedBatch &batch = bySize[k];
    batch.size = k;
    batch.instances.push_back(i);
    std::size_t base = batch.matrices.size();
    batch.matrices.resize(base + static_cast<std::size_t>(k * k), 0.0);
    double *c = batch.matrices.data() + base;
    const double *h = hessians + i * n * n;
    for (std::int64_t a = 0; a < n; ++a) {
      std::int64_t ca = m.compressed[a];
      if (ca < 0)
        continue;
      for (std::int64_t b = 0; b < n; ++b) {
        std::int64_t cb = m.compressed[b];
        if (cb >= 0)
          c[ca * k + cb] += h[a * n + b];
      }
    }
  }
  std::vector<CompressedBatch> out;
  for (auto &entry : bySize)
    out.push_back(std::move(entry.second));
  return out;
}

void yasps::runtime::expandLocalHessians(std::int64_t count, std::int64_t n,
                                         const std::int64_t *dofs,
                                         const CompressedBatch &batch,
                                         const double *projected, double *out) {
  const std::int64_t k = batch.size;
  for (std::size_t j = 0; j < batch.instances.size(); ++j) {
    std::int64_t i = batch.instances[j];
    if (i < 0 || i >= count)
      throw std::out_of_range("instance " + std::to_string(i) +
                              " of a compressed batch is outside the " +
                              std::to_string(count) + " instances");
    Mapping m = mappingOf(n, dofs + i * n);
    if (static_cast<std::int64_t>(m.first.size()) != k)
      throw std::invalid_argument(
          "instance " + std::to_string(i) + " compresses to " +
          std::to_string(m.first.size()) + " DoFs, not the batch's " +
          std::to_string(k));
    double *h = out + i * n * n;
    std::fill(h, h + n * n, 0.0);
    const double *p = projected + static_cast<std::int64_t>(j) * k * k;
    for (std::int64_t r = 0; r < k; ++r)
      for (std::int64_t c = 0; c < k; ++c)
        h[m.first[r] * n + m.first[c]] = p[r * k + c];
  }
}
