//===- Differentiator.h - forward-mode Jacobians of attributes -*- C++ -*-===//
//
// The engine of yasps-differentiate, private to the pass's files: parameter
// groups, the Jacobian of an attribute by forward mode over its region, and
// the helpers that the energy derivatives and the projection strategy share.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_LIB_DIALECT_YASPS_TRANSFORMS_DIFFERENTIATOR_H
#define YASPS_LIB_DIALECT_YASPS_TRANSFORMS_DIFFERENTIATOR_H

#include "yasps/Dialect/Yasps/IR/Yasps.h"
#include "yasps/Dialect/Yasps/Transforms/HessianFactors.h"

#include <map>
#include <optional>

namespace mlir::yasps::differentiation {

enum class GroupKind { Read, Join, Union };

/// A group of `count` parameter slots of `width` parameters each.
struct ParamGroup {
  GroupKind kind;
  Operation *key;  ///< target (read), connectivity (join), union entity
  Operation *base; ///< the attribute whose parameters a slot holds
  int64_t count;   ///< slots: JOIN arity, else 1
  int64_t width;   ///< parameters per slot
  int64_t offset = 0;
  int64_t leafEntries = 0; ///< entries of the leaf value (inner variables)

  int64_t size() const { return count * width; }
};

class Differentiator {
public:
  Differentiator(SceneOp scene, DenseSet<Operation *> targets,
                 SymbolTableCollection &tables)
      : scene(scene), targets(std::move(targets)), tables(tables) {}

  /// `X__jac`, or null when X depends on no target. With `inner`, the
  /// Jacobian `X__ijac` with respect to the entries of X's leaf values (the
  /// inner variables of the reduced-space projection) instead.
  FailureOr<AttrOp> jacobian(AttrOp attr, bool inner = false,
                             bool symmetric = false);

  /// The parameter groups of a computed attribute; with `inner`, one group
  /// per leaf with the leaf's entries as parameters.
  FailureOr<SmallVector<ParamGroup>> groupsOf(AttrOp attr, bool inner = false);

  /// True if the parameterisations behind E's leaves are linear (their
  /// second Jacobians are structurally zero): then the Hessian is
  /// J^T H_inner J exactly, and projecting H_inner suffices (paper 5.4).
  FailureOr<bool> curvatureFree(AttrOp energy);

  /// `E__ij`: d(leaf entries)/d(parameters), m x n, rows in the order of
  /// the inner groups.
  FailureOr<AttrOp> innerMap(AttrOp energy);

  /// E's linear cut (linearCut over the leaves of its parameter groups).
  FailureOr<SmallVector<Value>> innerCut(AttrOp energy);

  /// `E__ij` for a cut of E's region: d(cut entries)/d(parameters), k x n,
  /// the values' entries column-major in the cut's order.
  FailureOr<AttrOp> cutMap(AttrOp energy, ArrayRef<Value> cut);

  /// `E__ihess`: E's Hessian with respect to the entries of a cut of its
  /// region (k x k), or null when it is structurally zero.
  FailureOr<AttrOp> cutHessian(AttrOp energy, ArrayRef<Value> cut);

  /// yasps.params of an attribute: one entry per slot.
  ArrayAttr describe(ArrayRef<ParamGroup> groups);

  /// A new, empty attribute `name` after `next`, with `params` and, given
  /// `role`, `yasps.derivative = <role of next (or of)>`, inserted through
  /// the symbol table collection, which stays valid. Fails, with an error,
  /// when the name is taken.
  FailureOr<AttrOp>
  createAttr(AttrOp next, StringRef name, MatrixType type,
             Operation *derivedFromOp, ArrayAttr params,
             std::optional<DerivativeRole> role = std::nullopt,
             Operation *of = nullptr);

private:
  Operation *baseOf(Operation *decl) {
    for (auto it = derivedFrom.find(decl); it != derivedFrom.end();
         it = derivedFrom.find(decl))
      decl = it->second;
    return decl;
  }
  FailureOr<int64_t> paramCount(Operation *base);
  FailureOr<Value> seed(OpBuilder &b, Operation *leaf, const ParamGroup &group,
                        int64_t slot, int64_t local);
  FailureOr<Operation *> unionJacobian(Operation *member, StringAttr name,
                                       int64_t width);
  /// A unit matrix at column-major entry `local` of the leaf's value.
  Value unitSeed(OpBuilder &b, Operation *leaf, int64_t local);
  /// The leaves of a cloned region that belong to each group.
  SmallVector<std::pair<Operation *, const ParamGroup *>>
  leavesOf(AttrOp clone, ArrayRef<ParamGroup> groups);

  SceneOp scene;
  DenseSet<Operation *> targets;
  SymbolTableCollection &tables;
  DenseMap<Operation *, Operation *> derivedFrom;
  std::map<std::pair<Operation *, bool>, AttrOp> jacobians;
  DenseMap<Operation *, int64_t> counts;
  /// Gathers of a source's Jacobian, one per leaf, shared by directions.
  DenseMap<Operation *, Value> gathered;
  /// Padded member Jacobians of UNIONs that are structurally zero.
  DenseSet<Operation *> zeroUnionJacobians;
};

/// The values of `body` through which its `leaves` reach the yielded value:
/// affine in the leaves (their Hessian is structurally zero), and together
/// a cut (every path from a leaf to the yield crosses one), none of them
/// computed from the others alone. Empty when no leaf reaches the yield.
SmallVector<Value> linearCut(Block &body, const DenseSet<Operation *> &leaves);

/// The number of entries of a cut's values together.
int64_t cutEntries(ArrayRef<Value> cut);

/// A constant matrix of `type` from its entries in row-major order.
Value constantMatrix(OpBuilder &b, Location loc, MatrixType type,
                     ArrayRef<double> rowMajor);

/// Fails, with an error at `at`, when a derivative attribute `name` of
/// `type` would exceed the matrix type's limit (MatrixType::kMaxEntries).
LogicalResult checkSize(Operation *at, StringRef name, MatrixType type);

/// The zero matrix of `type`.
Value zeros(OpBuilder &b, Location loc, MatrixType type);

/// How yasps-differentiate projects local Hessians.
struct ProjectionOptions {
  HessianFactors factors = HessianFactors::never;
  /// Project in the entries of a linear cut (linearCut) where it has fewer
  /// entries than the leaves or the parameters (yasps-differentiate's
  /// linear-maps option).
  bool linearMaps = true;
};

/// Adds `@E__grad`, `@E__hess` and the projected Hessian of `energy`'s
/// computed attribute `attr`; false when it depends on no target.
FailureOr<bool> differentiateEnergy(Differentiator &diff, EnergyOp energy,
                                    AttrOp attr,
                                    const ProjectionOptions &options);

/// Adds the PSD projection of E's local Hessian `hessAttr`, by E's method:
/// in reduced space (paper 5.4) where the parameterisations behind E's
/// leaves are linear and the inner variables are fewer than the
/// parameters, else of the full Hessian. The inner variables are the
/// leaves' entries or, with `options.linearMaps` and where it is smaller,
/// a linear cut of E's region (paper 10.4: the 9 entries of F rather than
/// a tet's 12 positions). `@E__hess_proj` records which
/// (yasps.projection); as `options.factors` says, reduced factors in the
/// leaves stay apart (`@E__ij`, `@E__hess_inner_proj`, `@E__hess_inner`).
LogicalResult addProjectedHessian(Differentiator &diff, EnergyOp energy,
                                  AttrOp attr, AttrOp jac, AttrOp hessAttr,
                                  const ProjectionOptions &options);

} // namespace mlir::yasps::differentiation

#endif // YASPS_LIB_DIALECT_YASPS_TRANSFORMS_DIFFERENTIATOR_H
