//===- LinearCut.cpp - the affine frontier of an energy's region ----------===//
//
// Paper 10.4 without the user's rewrite. An energy of the deformation
// gradient F = Ds Dm^-1, which is affine in the corner positions, has the
// Hessian J_F^T (d2E/dF2) J_F, so its PSD projection can be taken on the
// 9x9 Hessian in F's entries instead of the 12x12 one in the positions. The
// values found here play F's part: they are affine in the region's leaves,
// and every path from a leaf to the energy passes through one of them.
//
//===----------------------------------------------------------------------===//

#include "Differentiator.h"
#include "Direction.h"

#include "mlir/IR/IRMapping.h"

using namespace mlir;
using namespace mlir::yasps;
using namespace mlir::yasps::differentiation;

namespace {

/// How a value depends on the leaves, as far as derivatives see.
enum class Dependence { none, affine, nonlinear };

Dependence join(Dependence a, Dependence b) { return std::max(a, b); }

/// The dependence of `op`'s result on the leaves from its operands'. Ops
/// whose derivative is zero (comparisons, stopped gradients) depend on
/// nothing; a product is affine when one factor is constant; a selection
/// is affine where both choices are, whatever its condition (the
/// derivative is taken piece by piece, as the forward mode does).
Dependence dependenceOf(Operation *op, ArrayRef<Dependence> operands) {
  Dependence all = Dependence::none;
  int dependent = 0;
  for (Dependence d : operands) {
    all = join(all, d);
    dependent += d != Dependence::none;
  }
  if (all == Dependence::none || isa<CmpOp, StopGradientOp>(op))
    return Dependence::none;
  if (all == Dependence::nonlinear)
    return Dependence::nonlinear;
  if (isa<NegOp, TransposeOp, RowOp, ColOp, ElementOp, SliceOp, ResizeOp, SumOp,
          TraceOp, AddOp, SubOp, ConcatOp>(op))
    return Dependence::affine;
  if (isa<MatmulOp, ElementwiseMulOp, ScaleOp, DotOp, CrossOp>(op))
    return dependent == 1 ? Dependence::affine : Dependence::nonlinear;
  if (auto div = dyn_cast<DivOp>(op))
    return operands[1] == Dependence::none ? Dependence::affine
                                           : Dependence::nonlinear;
  if (isa<SelectOp>(op))
    return join(operands[1], operands[2]);
  return Dependence::nonlinear;
}

/// Whether `value` is computed from `others` and leaf-independent values
/// alone (every path from a leaf to it crosses `others`).
bool determinedBy(Value value, const DenseSet<Value> &others,
                  const DenseSet<Operation *> &leaves,
                  const DenseMap<Value, Dependence> &dependence) {
  SmallVector<Value> stack{value};
  DenseSet<Value> seen;
  while (!stack.empty()) {
    Value v = stack.pop_back_val();
    if (!seen.insert(v).second)
      continue;
    if (v != value && others.contains(v))
      continue;
    if (dependence.lookup(v) == Dependence::none)
      continue;
    Operation *op = v.getDefiningOp();
    if (!op || leaves.contains(op))
      return false;
    llvm::append_range(stack, op->getOperands());
  }
  return true;
}

} // namespace

SmallVector<Value>
differentiation::linearCut(Block &body, const DenseSet<Operation *> &leaves) {
  DenseMap<Value, Dependence> dependence;
  SmallVector<Value> affine;
  for (Operation &op : body.without_terminator()) {
    Dependence d = Dependence::affine;
    if (!leaves.contains(&op)) {
      SmallVector<Dependence> operands;
      for (Value operand : op.getOperands())
        operands.push_back(dependence.lookup(operand));
      d = dependenceOf(&op, operands);
    }
    for (Value result : op.getResults()) {
      dependence[result] = d;
      if (d == Dependence::affine)
        affine.push_back(result);
    }
  }
  // The frontier: affine values that the energy itself or a nonlinear op
  // consumes. Every path from a leaf ends in one of them.
  auto consumedNonlinearly = [&](Value v) {
    for (Operation *user : v.getUsers())
      if (isa<YieldOp>(user) ||
          dependence.lookup(user->getResult(0)) == Dependence::nonlinear)
        return true;
    return false;
  };
  SmallVector<Value> frontier;
  for (Value v : affine)
    if (consumedNonlinearly(v))
      frontier.push_back(v);
  // Drop the members that the others determine (F^T beside F), latest
  // first: the rest still cuts every path.
  DenseSet<Value> kept(frontier.begin(), frontier.end());
  for (Value v : llvm::reverse(frontier)) {
    kept.erase(v);
    if (!determinedBy(v, kept, leaves, dependence))
      kept.insert(v);
  }
  SmallVector<Value> cut;
  for (Value v : frontier)
    if (kept.contains(v))
      cut.push_back(v);
  return cut;
}

FailureOr<SmallVector<Value>> Differentiator::innerCut(AttrOp energy) {
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(energy);
  if (failed(groups))
    return failure();
  DenseSet<Operation *> leaves;
  for (auto [op, group] : leavesOf(energy, *groups))
    leaves.insert(op);
  return linearCut(energy.getBodyBlock(), leaves);
}

int64_t differentiation::cutEntries(ArrayRef<Value> values) {
  int64_t k = 0;
  for (Value v : values)
    k += cast<MatrixType>(v.getType()).getNumElements();
  return k;
}

/// A copy of `from`'s computation at the end of `into`: the copy of its
/// yielded value, and `cut`'s copies in `clonedCut`.
static Value cloneBody(AttrOp from, AttrOp into, ArrayRef<Value> cut,
                       SmallVectorImpl<Value> &clonedCut) {
  IRMapping mapping;
  OpBuilder b = OpBuilder::atBlockEnd(&into.getBodyBlock());
  for (Operation &op : from.getBodyBlock().without_terminator())
    b.clone(op, mapping);
  for (Value v : cut)
    clonedCut.push_back(mapping.lookup(v));
  return mapping.lookup(
      cast<YieldOp>(from.getBodyBlock().getTerminator()).getValue());
}

/// Entry `index` of the cut, counted column-major value after value: the
/// value's position in the cut and the entry's within it.
static std::pair<size_t, int64_t> locate(ArrayRef<Value> cut, int64_t index) {
  for (size_t i = 0; i < cut.size(); ++i) {
    int64_t n = cast<MatrixType>(cut[i].getType()).getNumElements();
    if (index < n)
      return {i, index};
    index -= n;
  }
  llvm_unreachable("entry beyond the cut");
}

FailureOr<AttrOp> Differentiator::cutMap(AttrOp energy, ArrayRef<Value> cut) {
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(energy);
  if (failed(groups))
    return failure();
  int64_t k = cutEntries(cut);
  int64_t d =
      groups->empty() ? 0 : groups->back().offset + groups->back().size();
  MatrixType scalar = energy.getMatrixType();
  FailureOr<AttrOp> created = createAttr(
      energy, (energy.getSymName() + "__ij").str(), scalar.withShape(k, d),
      nullptr, ArrayAttr(), DerivativeRole::ij);
  if (failed(created))
    return failure();
  AttrOp map = *created;
  SmallVector<Value> clonedCut;
  cloneBody(energy, map, cut, clonedCut);
  SmallVector<std::pair<Operation *, const ParamGroup *>> leaves =
      leavesOf(map, *groups);
  OpBuilder b = OpBuilder::atBlockEnd(&map.getBodyBlock());
  Location loc = energy.getLoc();
  // Column p: the tangents of the cut's values in parameter p's direction,
  // each flattened column-major, stacked in the cut's order.
  SmallVector<Value> columns;
  for (const ParamGroup &g : *groups) {
    for (int64_t p = 0; p < g.size(); ++p) {
      bool failedSeed = false;
      auto seedFn = [&](Operation *leaf) -> FailureOr<Value> {
        for (auto [op, group] : leaves)
          if (op == leaf && group == &g) {
            FailureOr<Value> s = seed(b, leaf, g, p / g.width, p % g.width);
            failedSeed |= failed(s);
            return s;
          }
        return Value();
      };
      Direction direction(b, seedFn);
      SmallVector<Value> blocks;
      for (Value v : clonedCut) {
        MatrixType block =
            scalar.withShape(cast<MatrixType>(v.getType()).getNumElements(), 1);
        FailureOr<Value> t = direction.tangent(v);
        if (failed(t) || failedSeed)
          return failure();
        blocks.push_back(*t ? ResizeOp::create(b, loc, block, *t).getResult()
                            : zeros(b, loc, block));
      }
      columns.push_back(blocks.size() == 1
                            ? blocks[0]
                            : ConcatOp::create(b, loc, scalar.withShape(k, 1),
                                               ConcatAxis::vertical, blocks)
                                  .getResult());
    }
  }
  Value result = columns.size() == 1
                     ? columns[0]
                     : ConcatOp::create(b, loc, scalar.withShape(k, d),
                                        ConcatAxis::horizontal, columns)
                           .getResult();
  YieldOp::create(b, loc, result);
  return map;
}

FailureOr<AttrOp> Differentiator::cutHessian(AttrOp energy,
                                             ArrayRef<Value> cut) {
  int64_t k = cutEntries(cut);
  MatrixType scalar = energy.getMatrixType();
  FailureOr<AttrOp> created =
      createAttr(energy, (energy.getSymName() + "__ihess").str(),
                 scalar.withShape(k, k), energy, ArrayAttr());
  if (failed(created))
    return failure();
  AttrOp hess = *created;
  SmallVector<Value> clonedCut;
  Value root = cloneBody(energy, hess, cut, clonedCut);
  OpBuilder b = OpBuilder::atBlockEnd(&hess.getBodyBlock());
  Location loc = energy.getLoc();
  auto noLeaf = [](Operation *) -> FailureOr<Value> { return Value(); };
  auto seedAt = [&](int64_t entry) {
    return [&, entry](size_t index) -> Value {
      auto [at, local] = locate(clonedCut, entry);
      return at == index ? unitSeed(b, clonedCut[at].getDefiningOp(), local)
                         : Value();
    };
  };
  // Forward over forward with the cut as the variables: the gradient's
  // entries, then each one's tangents, the upper triangle mirrored.
  SmallVector<Value> gradient;
  for (int64_t p = 0; p < k; ++p) {
    auto seedP = seedAt(p);
    Direction direction(b, noLeaf, clonedCut, seedP);
    FailureOr<Value> g = direction.tangent(root);
    if (failed(g))
      return failure();
    gradient.push_back(*g);
  }
  SmallVector<Value> upper(k * k);
  bool anyNonZero = false;
  for (int64_t q = 0; q < k; ++q) {
    auto seedQ = seedAt(q);
    Direction direction(b, noLeaf, clonedCut, seedQ);
    for (int64_t p = q; p < k; ++p) {
      if (!gradient[p])
        continue;
      FailureOr<Value> h = direction.tangent(gradient[p]);
      if (failed(h))
        return failure();
      upper[q * k + p] = *h;
      anyNonZero |= static_cast<bool>(*h);
    }
  }
  if (!anyNonZero) {
    derivedFrom.erase(hess);
    tables.getSymbolTable(getOwningEntity(energy)).erase(hess);
    return AttrOp();
  }
  MatrixType one = scalar.withShape(1, 1);
  SmallVector<Value> columns;
  for (int64_t p = 0; p < k; ++p) {
    SmallVector<Value> column;
    for (int64_t i = 0; i < k; ++i) {
      Value v = upper[std::min(i, p) * k + std::max(i, p)];
      column.push_back(v ? v : zeros(b, loc, one));
    }
    columns.push_back(k == 1 ? column[0]
                             : ConcatOp::create(b, loc, scalar.withShape(k, 1),
                                                ConcatAxis::vertical, column)
                                   .getResult());
  }
  Value result = k == 1 ? columns[0]
                        : ConcatOp::create(b, loc, scalar.withShape(k, k),
                                           ConcatAxis::horizontal, columns)
                              .getResult();
  YieldOp::create(b, loc, result);
  return hess;
}
