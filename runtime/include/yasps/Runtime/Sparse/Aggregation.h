//===- Aggregation.h - grouping DoF blocks for a coarser level --*- C++ -*-===//
//
// The multilevel preconditioner (Multilevel.h) solves a coarser copy of the
// Hessian whose DoFs are aggregates: groups of neighbouring DoF blocks that
// move together (a translation of every member). Aggregates come from the
// matrix's block graph alone, by the greedy rule of plain aggregation
// (Vanek, Mandel and Brezina 1996): a block whose neighbours are all still
// free takes them into a new aggregate; a block left over joins the
// aggregate of its first aggregated neighbour. On a tet mesh that gives
// aggregates of a vertex and its one-ring, about 15 vertices.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_SPARSE_AGGREGATION_H
#define YASPS_RUNTIME_SPARSE_AGGREGATION_H

#include "yasps/Runtime/Sparse/BlockJacobi.h"

#include <cstdint>
#include <vector>

namespace yasps::runtime {

struct Aggregates {
  /// Per block of the fine layout, its aggregate (-1 for an empty block).
  std::vector<std::int64_t> of;
  /// Per aggregate, its DoF count: that of each of its members, which all
  /// have one block size.
  std::vector<std::int64_t> size;

  std::int64_t count() const { return static_cast<std::int64_t>(size.size()); }
};

/// Aggregates the blocks of the parts' common layout along the blocks that
/// any part stores off the diagonal. Only blocks of equal size share an
/// aggregate; a block no other couples to stays alone.
Aggregates aggregateBlocks(const HessianParts &parts);

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_SPARSE_AGGREGATION_H
