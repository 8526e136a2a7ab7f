//===- SlotFactors.cpp - local Hessians from shared member Jacobians ------===//

#include "yasps/Runtime/Assembly/SlotFactors.h"

#include <stdexcept>
#include <string>

using namespace yasps::runtime;

void SlotFactors::check(std::int64_t count, std::int64_t numParams) const {
  const std::int64_t numSlots = static_cast<std::int64_t>(slots.size());
  for (const JacobianTable &t : tables)
    if (t.instances < 0 || t.rows < 0 || t.cols < 0 ||
        (t.instances > 0 && !t.values))
      throw std::invalid_argument("a Jacobian table has no values");
  for (std::int64_t i = 0; i < count; ++i)
    for (std::int64_t s = 0; s < numSlots; ++s) {
      std::int64_t table = sources[(i * numSlots + s) * 2];
      std::int64_t at = sources[(i * numSlots + s) * 2 + 1];
      if (table < 0)
        continue;
      auto where = [&] {
        return "instance " + std::to_string(i) + ", slot " + std::to_string(s);
      };
      if (table >= static_cast<std::int64_t>(tables.size()))
        throw std::invalid_argument(where() + ": no Jacobian table " +
                                    std::to_string(table));
      const JacobianTable &t = tables[table];
      if (at < 0 || at >= t.instances)
        throw std::invalid_argument(where() + ": row " + std::to_string(at) +
                                    " of a Jacobian table of " +
                                    std::to_string(t.instances));
      const SlotPlacement &p = slots[s];
      std::int64_t last = p.innerStart + (t.rows - 1) * p.innerStride;
      if (t.rows > 0 &&
          (p.innerStart < 0 || p.innerStride < 1 || last >= numInner))
        throw std::invalid_argument(where() + ": inner entries outside the " +
                                    std::to_string(numInner) +
                                    " inner variables");
      if (p.column < 0 || p.column + t.cols > numParams)
        throw std::invalid_argument(where() + ": parameters outside the " +
                                    std::to_string(numParams) +
                                    " local parameters");
    }
}

void SlotFactors::formLocal(std::int64_t i, std::int64_t n,
                            const double *gInner, const double *p, double *g,
                            double *h, double *scratch) const {
  const std::int64_t m = numInner;
  const std::int64_t numSlots = static_cast<std::int64_t>(slots.size());
  const std::int64_t *mine = sources + i * numSlots * 2;
  auto jacobianOf = [&](std::int64_t s) -> const JacobianTable * {
    return mine[2 * s] < 0 ? nullptr : &tables[mine[2 * s]];
  };
  auto valuesOf = [&](std::int64_t s) {
    const JacobianTable &t = tables[mine[2 * s]];
    return t.values + mine[2 * s + 1] * t.rows * t.cols;
  };
  // PJ (m x n, only the slots' columns): P times each slot's block of J.
  for (std::int64_t s = 0; s < numSlots; ++s) {
    const JacobianTable *t = jacobianOf(s);
    if (!t)
      continue;
    const double *j = valuesOf(s);
    const SlotPlacement &place = slots[s];
    for (std::int64_t k = 0; k < m; ++k)
      for (std::int64_t c = 0; c < t->cols; ++c) {
        double sum = 0.0;
        for (std::int64_t e = 0; e < t->rows; ++e)
          sum += p[k * m + place.innerStart + e * place.innerStride] *
                 j[e * t->cols + c];
        scratch[k * n + place.column + c] = sum;
      }
  }
  // g = J^T gInner and H = J^T (PJ), block by block of slots (upper blocks,
  // mirrored: H is symmetric).
  for (std::int64_t s = 0; s < numSlots; ++s) {
    const JacobianTable *t = jacobianOf(s);
    if (!t)
      continue;
    const double *j = valuesOf(s);
    const SlotPlacement &place = slots[s];
    for (std::int64_t a = 0; a < t->cols; ++a) {
      double sum = 0.0;
      for (std::int64_t e = 0; e < t->rows; ++e)
        sum += j[e * t->cols + a] *
               gInner[place.innerStart + e * place.innerStride];
      g[place.column + a] = sum;
    }
    for (std::int64_t u = s; u < numSlots; ++u) {
      const JacobianTable *other = jacobianOf(u);
      if (!other)
        continue;
      const SlotPlacement &to = slots[u];
      for (std::int64_t a = 0; a < t->cols; ++a)
        for (std::int64_t b = 0; b < other->cols; ++b) {
          double sum = 0.0;
          for (std::int64_t e = 0; e < t->rows; ++e)
            sum += j[e * t->cols + a] *
                   scratch[(place.innerStart + e * place.innerStride) * n +
                           to.column + b];
          std::int64_t row = place.column + a, col = to.column + b;
          h[row * n + col] = h[col * n + row] = sum;
        }
    }
  }
}
