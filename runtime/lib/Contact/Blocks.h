//===- Blocks.h - ordered parallel loops of the contact stages --*- C++ -*-===//
//
// The broad phase, narrow phase and CCD loop over primitives or candidate
// pairs. They run in numbered blocks on the runtime's thread pool, each
// block writing its own output: concatenated by block number, the outputs
// come in the order of a serial loop, so results do not depend on the
// number of threads.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_LIB_CONTACT_BLOCKS_H
#define YASPS_RUNTIME_LIB_CONTACT_BLOCKS_H

#include "yasps/Runtime/Support/ThreadPool.h"

#include <algorithm>
#include <cstdint>

namespace yasps::runtime::contact {

/// Blocks of at least `minBlock` items, a few per thread so that uneven
/// blocks even out; one block without a pool.
inline int64_t blockCount(const ThreadPool *pool, int64_t count,
                          int64_t minBlock) {
  if (!pool || pool->size() < 2 || count <= minBlock)
    return 1;
  return std::min<int64_t>((count + minBlock - 1) / minBlock,
                           4 * static_cast<int64_t>(pool->size()));
}

/// Runs body(block, begin, end) for `blocks` contiguous blocks that
/// partition [0, count), on `pool` (inline without one).
template <typename Body>
void forBlocks(ThreadPool *pool, int64_t count, int64_t blocks, Body &&body) {
  int64_t size = (count + blocks - 1) / std::max<int64_t>(blocks, 1);
  auto run = [&](int64_t first, int64_t last) {
    for (int64_t b = first; b < last; ++b)
      body(b, std::min(count, b * size), std::min(count, (b + 1) * size));
  };
  if (!pool || blocks <= 1)
    return run(0, blocks);
  pool->parallelFor(0, blocks, 1, run);
}

} // namespace yasps::runtime::contact

#endif // YASPS_RUNTIME_LIB_CONTACT_BLOCKS_H
