//===- Aggregation.cpp - grouping DoF blocks for a coarser level ----------===//

#include "yasps/Runtime/Sparse/Aggregation.h"

using namespace yasps::runtime;

namespace {
/// The symmetric block graph of the parts, as adjacency lists in CSR form,
/// with edges only between non-empty blocks of one size.
struct BlockGraph {
  std::vector<std::size_t> start;
  std::vector<std::int64_t> neighbour;

  explicit BlockGraph(const HessianParts &parts) {
    const BlockLayout &layout = parts.front()->layout();
    const std::int64_t n = layout.numBlocks();
    auto linked = [&](std::int64_t i, std::int64_t j) {
      return i != j && layout.blockSize(i) > 0 &&
             layout.blockSize(i) == layout.blockSize(j);
    };
    start.assign(static_cast<std::size_t>(n) + 1, 0);
    for (const BlockSparseMatrix *part : parts)
      for (std::size_t b = 0; b < part->numStoredBlocks(); ++b) {
        std::int64_t i = part->blockRow(b), j = part->blockCol(b);
        if (linked(i, j)) {
          ++start[i + 1];
          ++start[j + 1];
        }
      }
    for (std::int64_t i = 0; i < n; ++i)
      start[i + 1] += start[i];
    neighbour.resize(start.back());
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (const BlockSparseMatrix *part : parts)
      for (std::size_t b = 0; b < part->numStoredBlocks(); ++b) {
        std::int64_t i = part->blockRow(b), j = part->blockCol(b);
        if (linked(i, j)) {
          neighbour[fill[i]++] = j;
          neighbour[fill[j]++] = i;
        }
      }
  }
};
} // namespace

Aggregates yasps::runtime::aggregateBlocks(const HessianParts &parts) {
  const BlockLayout &layout = parts.front()->layout();
  const std::int64_t n = layout.numBlocks();
  const BlockGraph graph(parts);
  Aggregates result;
  result.of.assign(static_cast<std::size_t>(n), -1);
  auto newAggregate = [&](std::int64_t block) {
    result.size.push_back(layout.blockSize(block));
    return result.count() - 1;
  };
  // Pass 1: a block whose neighbours are all free takes them.
  for (std::int64_t i = 0; i < n; ++i) {
    if (result.of[i] >= 0 || layout.blockSize(i) == 0)
      continue;
    bool allFree = true;
    for (std::size_t e = graph.start[i]; e < graph.start[i + 1] && allFree; ++e)
      allFree = result.of[graph.neighbour[e]] < 0;
    if (!allFree)
      continue;
    std::int64_t a = newAggregate(i);
    result.of[i] = a;
    for (std::size_t e = graph.start[i]; e < graph.start[i + 1]; ++e)
      result.of[graph.neighbour[e]] = a;
  }
  // Pass 2: every block left has an aggregated neighbour (else pass 1 would
  // have taken it), whose aggregate it joins.
  for (std::int64_t i = 0; i < n; ++i) {
    if (result.of[i] >= 0 || layout.blockSize(i) == 0)
      continue;
    for (std::size_t e = graph.start[i]; e < graph.start[i + 1]; ++e) {
      std::int64_t a = result.of[graph.neighbour[e]];
      if (a >= 0) {
        result.of[i] = a;
        break;
      }
    }
  }
  return result;
}
