//===- SlotFactors.h - local Hessians from shared member Jacobians -*- C++
//-*-===//
//
// An energy reached through linear parameterisations (paper 5.4) has the
// local Hessian J^T P J, with P the projected Hessian in its m inner
// variables (the world-space entries of its leaves) and J their Jacobian.
// J is block-diagonal by slot: the entries a JOIN gathers at one slot
// depend only on the parameters of the instance found there. So J need not
// be stored per energy instance, padded to the widest UNION member: each
// slot's block is a row of a table of Jacobians kept per source (a UNION
// member's vertices, say), computed once per Newton iteration by that
// member's own kernel and shared by every energy that reaches it (paper
// 7.1, 10.9, appendix E.3.3). Per instance only the m inner gradient
// entries, the m x m matrix P and a reference per slot remain.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_ASSEMBLY_SLOTFACTORS_H
#define YASPS_RUNTIME_ASSEMBLY_SLOTFACTORS_H

#include <cstdint>
#include <vector>

namespace yasps::runtime {

/// The Jacobians of one source of slot parameters: `instances` matrices of
/// `rows` inner entries by `cols` parameters, each row-major.
struct JacobianTable {
  const double *values = nullptr;
  std::int64_t instances = 0, rows = 0, cols = 0;
};

/// Where one slot sits in an energy instance's local system: its inner
/// entry e (e < its table's rows) is inner variable innerStart +
/// e * innerStride, and its parameters are the local columns from `column`
/// on (the table's cols of them; the rest of the slot is UNION padding).
struct SlotPlacement {
  std::int64_t innerStart = 0, innerStride = 1, column = 0;
};

/// The factors of one energy: `numInner` (m) inner variables, its slots,
/// and for every instance and slot the (table, instance) it reads, as
/// count x slots x 2 integers; table -1 for a slot without parameters.
struct SlotFactors {
  std::int64_t numInner = 0;
  std::vector<JacobianTable> tables;
  std::vector<SlotPlacement> slots;
  const std::int64_t *sources = nullptr;

  /// Throws std::invalid_argument, naming the instance and slot, unless
  /// every reference of `count` instances is in bounds and every slot fits
  /// `numInner` inner variables and `numParams` local parameters.
  void check(std::int64_t count, std::int64_t numParams) const;

  /// Instance i's local gradient g = J^T gInner (n entries) and Hessian
  /// H = J^T P J (n x n, row-major) from its inner gradient (m) and P
  /// (m x m, row-major). Only the entries of slot parameters are written;
  /// the columns of UNION padding are left as they are (assembly skips
  /// them). `scratch` holds at least m * n doubles.
  void formLocal(std::int64_t i, std::int64_t n, const double *gInner,
                 const double *p, double *g, double *h, double *scratch) const;
};

} // namespace yasps::runtime

#endif // YASPS_RUNTIME_ASSEMBLY_SLOTFACTORS_H
