//===- Differentiate.cpp - local gradients and Hessians of energies -------===//
//
// Forward mode over the energy's region: the local parameters are the entries
// of the minimisation targets the region reads directly or gathers through
// JOINs. One tangent per parameter gives the gradient; applying the tangent
// rules again to the code of each gradient entry gives the Hessian (upper
// triangle, mirrored). Tangents are cached per direction, so a sub-expression
// shared by several entries is differentiated once per direction, and CSE
// afterwards merges what the directions have in common.
//
//===----------------------------------------------------------------------===//

#include "yasps/Dialect/Yasps/Transforms/Passes.h"

#include "mlir/IR/IRMapping.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSDIFFERENTIATE
#include "yasps/Dialect/Yasps/Transforms/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {

/// A group of local parameters: the entries of one target value that the
/// energy reads directly, or of the l-th instance a JOIN gathers.
struct ParamSlot {
  Operation *leaf;    ///< the read or join op in the energy's region
  int64_t joinRow;    ///< row of the JOIN result, -1 for a direct read
  int64_t size;       ///< number of parameters (r*c of the target)
  int64_t offset = 0; ///< index of the first parameter
  Attribute description;
};

/// Tangents of the values of one region in one direction (one parameter).
class DirectionalDerivative {
public:
  DirectionalDerivative(OpBuilder &builder,
                        DenseMap<Operation *, const ParamSlot *> &slots,
                        int64_t param)
      : builder(builder), slots(slots), param(param) {}

  /// The tangent of `value` (null when it is zero).
  FailureOr<Value> tangent(Value value) {
    if (auto it = cache.find(value); it != cache.end())
      return it->second;
    Operation *op = value.getDefiningOp();
    FailureOr<Value> result = Value();
    if (isa<ReadOp, JoinOp, UnionOp>(op)) {
      result = seed(op);
    } else {
      SmallVector<Value> operandTangents;
      for (Value operand : op->getOperands()) {
        FailureOr<Value> t = tangent(operand);
        if (failed(t))
          return failure();
        operandTangents.push_back(*t);
      }
      result = cast<DifferentiableOpInterface>(op).emitTangent(
          builder, operandTangents);
    }
    if (succeeded(result))
      cache[value] = *result;
    return result;
  }

private:
  /// A unit matrix at this direction's entry of a leaf, or zero.
  FailureOr<Value> seed(Operation *leaf) {
    auto it = slots.find(leaf);
    auto type = cast<MatrixType>(leaf->getResult(0).getType());
    if (it == slots.end())
      return Value(); // constants and non-target attributes
    const ParamSlot &slot = *it->second;
    int64_t local = param - slot.offset;
    if (local < 0 || local >= slot.size) {
      // A JOIN leaf holds several slots; only the one of `param` seeds it.
      return Value();
    }
    // Entry `local` of a read target value is column-major; a JOIN result
    // holds one flattened target value per row.
    bool join = isa<JoinOp>(leaf);
    int64_t row = join ? local / type.getCols() : local % type.getRows();
    int64_t col = join ? local % type.getCols() : local / type.getRows();
    SmallVector<double> values(type.getNumElements(), 0.0);
    values[row * type.getCols() + col] = 1.0; // dense literals are row-major
    auto attr = DenseElementsAttr::get(type.getTensorType(),
                                       ArrayRef<double>(values));
    if (type.getElementType().isF32()) {
      SmallVector<float> floats(values.begin(), values.end());
      attr = DenseElementsAttr::get(type.getTensorType(),
                                    ArrayRef<float>(floats));
    }
    return ConstantOp::create(builder, leaf->getLoc(), type, attr).getResult();
  }

  OpBuilder &builder;
  DenseMap<Operation *, const ParamSlot *> &slots;
  int64_t param;
  DenseMap<Value, Value> cache;
};

struct DifferentiatePass
    : public mlir::yasps::impl::YaspsDifferentiateBase<DifferentiatePass> {
  void runOnOperation() override;
  LogicalResult differentiate(SceneOp scene, MinimizeOp targets,
                              EnergyOp energy, SymbolTableCollection &tables);
};

/// Finds the local parameters of `attr`: reads of targets and JOINs of
/// targets, in the order they appear.
FailureOr<SmallVector<ParamSlot>>
collectSlots(AttrOp attr, SceneOp scene, const DenseSet<Operation *> &targets,
             SymbolTableCollection &tables) {
  SmallVector<ParamSlot> slots;
  MLIRContext *ctx = attr.getContext();
  DenseSet<Operation *> seenReads;
  for (Operation &op : attr.getBodyBlock()) {
    if (auto read = dyn_cast<ReadOp>(op)) {
      Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
      if (isa<AttrOp>(decl))
        return read.emitOpError()
               << "reads " << describe(decl)
               << ": inline computed attributes (yasps-inline-reads) before "
                  "yasps-differentiate",
               failure();
      if (!targets.contains(decl))
        continue;
      if (!seenReads.insert(decl).second)
        return read.emitOpError()
               << "reads " << describe(decl)
               << " twice; run cse before yasps-differentiate",
               failure();
      slots.push_back({read, -1, getAttributeType(decl).getNumElements(), 0,
                       ArrayAttr::get(ctx, {StringAttr::get(ctx, "read"),
                                            read.getAttribute()})});
    } else if (auto join = dyn_cast<JoinOp>(op)) {
      Operation *source = lookupInScene(scene, join.getSource(), &tables);
      if (isa<AttrOp>(source))
        return join.emitOpError()
               << "gathers " << describe(source)
               << ": differentiating through a JOIN of a computed attribute "
                  "is not supported yet",
               failure();
      if (!targets.contains(source))
        continue;
      int64_t rows = cast<MatrixType>(join.getType()).getRows();
      int64_t size = getAttributeType(source).getNumElements();
      for (int64_t l = 0; l < rows; ++l)
        slots.push_back(
            {join, l, size, 0,
             ArrayAttr::get(ctx, {StringAttr::get(ctx, "join"),
                                  join.getConnectivityAttr(),
                                  IntegerAttr::get(IntegerType::get(ctx, 64), l),
                                  join.getSource()})});
    } else if (auto unionOp = dyn_cast<UnionOp>(op)) {
      return unionOp.emitOpError()
             << "differentiating through a UNION is not supported yet",
             failure();
    }
  }
  int64_t offset = 0;
  for (ParamSlot &slot : slots) {
    slot.offset = offset;
    offset += slot.size;
  }
  return slots;
}

} // namespace

LogicalResult DifferentiatePass::differentiate(SceneOp scene,
                                               MinimizeOp targetsOp,
                                               EnergyOp energy,
                                               SymbolTableCollection &tables) {
  auto attr = dyn_cast_or_null<AttrOp>(
      lookupInScene(scene, energy.getAttribute(), &tables));
  if (!attr)
    return energy.emitOpError()
           << "energy " << energy.getAttribute()
           << " is not a computed attribute; nothing to differentiate";
  DenseSet<Operation *> targets;
  for (auto ref : targetsOp.getTargets().getAsRange<SymbolRefAttr>())
    targets.insert(lookupInScene(scene, ref, &tables));
  FailureOr<SmallVector<ParamSlot>> slots =
      collectSlots(attr, scene, targets, tables);
  if (failed(slots))
    return failure();
  int64_t n = slots->empty() ? 0 : slots->back().offset + slots->back().size;
  if (n == 0)
    return success(); // depends on no target: no derivative to assemble
  SmallVector<Attribute> descriptions;
  for (const ParamSlot &slot : *slots)
    descriptions.push_back(slot.description);
  // JOIN leaves own several consecutive slots of equal size: widen the first
  // slot's range to cover them all.
  SmallVector<ParamSlot> merged;
  for (const ParamSlot &slot : *slots) {
    if (!merged.empty() && merged.back().leaf == slot.leaf) {
      merged.back().size += slot.size;
      continue;
    }
    merged.push_back(slot);
  }
  DenseMap<Operation *, const ParamSlot *> leafSlots;
  for (const ParamSlot &slot : merged)
    leafSlots[slot.leaf] = &slot;

  MatrixType scalar = attr.getMatrixType();
  auto paramsAttr = ArrayAttr::get(&getContext(), descriptions);
  OpBuilder outside(attr->getBlock(), std::next(Block::iterator(attr)));
  auto makeAttr = [&](StringRef suffix, MatrixType type) {
    auto result = AttrOp::create(
        outside, attr.getLoc(),
        StringAttr::get(&getContext(), attr.getSymName() + suffix),
        TypeAttr::get(type));
    result->setAttr("yasps.params", paramsAttr);
    Block *block = new Block();
    result.getBody().push_back(block);
    // The energy's computation, then its derivatives.
    IRMapping mapping;
    OpBuilder inside = OpBuilder::atBlockEnd(block);
    for (Operation &op : attr.getBodyBlock().without_terminator())
      inside.clone(op, mapping);
    return std::make_tuple(result, mapping);
  };

  auto [grad, gradMap] = makeAttr("__grad", scalar.withShape(n, 1));
  auto [hess, hessMap] = makeAttr("__hess", scalar.withShape(n, n));
  Value energyValue =
      cast<YieldOp>(attr.getBodyBlock().getTerminator()).getValue();

  // Gradient and Hessian entries, each built in its attribute's region.
  auto entries = [&](AttrOp target, IRMapping &mapping,
                     bool second) -> FailureOr<SmallVector<Value>> {
    Block &block = target.getBodyBlock();
    OpBuilder b = OpBuilder::atBlockEnd(&block);
    DenseMap<Operation *, const ParamSlot *> mappedSlots;
    for (auto [leaf, slot] : leafSlots)
      mappedSlots[mapping.lookup(leaf->getResult(0)).getDefiningOp()] = slot;
    Value root = mapping.lookup(energyValue);
    SmallVector<DirectionalDerivative> directions;
    for (int64_t k = 0; k < n; ++k)
      directions.emplace_back(b, mappedSlots, k);
    SmallVector<Value> gradient;
    for (int64_t k = 0; k < n; ++k) {
      FailureOr<Value> g = directions[k].tangent(root);
      if (failed(g))
        return failure();
      gradient.push_back(*g);
    }
    if (!second)
      return gradient;
    SmallVector<Value> hessian(n * n);
    for (int64_t k = 0; k < n; ++k)
      for (int64_t l = k; l < n && gradient[k]; ++l) {
        FailureOr<Value> h = directions[l].tangent(gradient[k]);
        if (failed(h))
          return failure();
        hessian[k * n + l] = hessian[l * n + k] = *h;
      }
    return hessian;
  };

  auto finish = [&](AttrOp target, ArrayRef<Value> values, int64_t rows,
                    int64_t cols) {
    OpBuilder b = OpBuilder::atBlockEnd(&target.getBodyBlock());
    Location loc = target.getLoc();
    Value zero;
    SmallVector<Value> rowValues;
    for (int64_t r = 0; r < rows; ++r) {
      SmallVector<Value> parts;
      for (int64_t c = 0; c < cols; ++c) {
        Value v = values[r * cols + c];
        if (!v) {
          if (!zero)
            zero = ConstantOp::create(
                b, loc, scalar,
                DenseElementsAttr::get(
                    scalar.getTensorType(),
                    b.getFloatAttr(scalar.getElementType(), 0.0)));
          v = zero;
        }
        parts.push_back(v);
      }
      rowValues.push_back(
          cols == 1 ? parts[0]
                    : ConcatOp::create(b, loc, scalar.withShape(1, cols),
                                       ConcatAxis::horizontal, parts)
                          .getResult());
    }
    Value result =
        rows == 1 ? rowValues[0]
                  : ConcatOp::create(b, loc, scalar.withShape(rows, cols),
                                     ConcatAxis::vertical, rowValues)
                        .getResult();
    YieldOp::create(b, loc, result);
  };

  FailureOr<SmallVector<Value>> g = entries(grad, gradMap, false);
  if (failed(g))
    return failure();
  finish(grad, *g, n, 1);
  FailureOr<SmallVector<Value>> h = entries(hess, hessMap, true);
  if (failed(h))
    return failure();
  finish(hess, *h, n, n);
  return success();
}

void DifferentiatePass::runOnOperation() {
  SymbolTableCollection tables;
  for (auto scene : getOperation().getOps<SceneOp>()) {
    auto targets = scene.getBodyBlock().getOps<MinimizeOp>();
    if (targets.empty())
      continue;
    for (auto energy : scene.getBodyBlock().getOps<EnergyOp>())
      if (failed(differentiate(scene, *targets.begin(), energy, tables)))
        return signalPassFailure();
  }
}
