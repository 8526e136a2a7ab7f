//===- Differentiate.cpp - Jacobians of attributes, energy derivatives ----===//
//
// The unit of differentiation is a named attribute X and its local
// parameters: groups of entries of minimisation targets that X reaches
// through its region's leaves (paper section 5.3's boundary nodes):
//
//   - a read of a target on X's lineage: its r*c entries;
//   - a JOIN of an attribute whose *base* depends on targets: per gathered
//     instance, the base's own parameters (r*c entries of a stored target,
//     or the parameters of a computed source, recursively);
//   - a UNION: the parameters of the member the instance belongs to, padded
//     to the widest member (paper 5.2).
//
// `X__jac` (rc x d) holds dvec(X)/dparams: forward mode over X's region, one
// tangent per parameter, seeded at the leaves. Seeds of a JOIN or UNION of a
// computed attribute come from that attribute's own `__jac`, gathered the
// same way (paper 5.1/5.2): derivatives are computed once per boundary
// attribute and reused by every energy that gathers it. A derivative
// attribute has its base's parameters, so the Jacobian of `E__jac` is the
// Hessian of E, with the curvature terms of nonlinear parameterisations
// coming from the sources' second Jacobians.
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

  /// yasps.params of an attribute: one entry per slot.
  ArrayAttr describe(ArrayRef<ParamGroup> groups);

  /// A new, empty attribute `name` after `next`, with `params` and, given
  /// `role`, `yasps.derivative = <role of next's base>`.
  AttrOp createAttr(AttrOp next, StringRef name, MatrixType type,
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

/// Tangents of one region's values in one direction.
class Direction {
public:
  using SeedFn = function_ref<FailureOr<Value>(Operation *leaf)>;
  Direction(OpBuilder &b, SeedFn seedFn) : b(b), seedFn(seedFn) {}

  FailureOr<Value> tangent(Value value) {
    if (auto it = cache.find(value); it != cache.end())
      return it->second;
    Operation *op = value.getDefiningOp();
    FailureOr<Value> result = Value();
    if (isa<ReadOp, JoinOp, UnionOp>(op)) {
      result = seedFn(op);
    } else {
      SmallVector<Value> operandTangents;
      for (Value operand : op->getOperands()) {
        FailureOr<Value> t = tangent(operand);
        if (failed(t))
          return failure();
        operandTangents.push_back(*t);
      }
      result =
          cast<DifferentiableOpInterface>(op).emitTangent(b, operandTangents);
    }
    if (succeeded(result))
      cache[value] = *result;
    return result;
  }

private:
  OpBuilder &b;
  SeedFn seedFn;
  DenseMap<Value, Value> cache;
};

Value constantMatrix(OpBuilder &b, Location loc, MatrixType type,
                     ArrayRef<double> rowMajor) {
  SmallVector<APFloat> values;
  for (double v : rowMajor) {
    APFloat f(v);
    bool lost;
    f.convert(type.getElementType().getFloatSemantics(),
              APFloat::rmNearestTiesToEven, &lost);
    values.push_back(f);
  }
  return ConstantOp::create(
      b, loc, type, DenseElementsAttr::get(type.getTensorType(), values));
}

Value zeros(OpBuilder &b, Location loc, MatrixType type) {
  return constantMatrix(b, loc, type,
                        SmallVector<double>(type.getNumElements(), 0.0));
}

/// A k x c matrix that is `row` in row `at` and zero elsewhere.
Value embedRow(OpBuilder &b, Location loc, Value row, int64_t at, int64_t k) {
  auto type = cast<MatrixType>(row.getType());
  if (k == 1)
    return row;
  SmallVector<Value> parts;
  if (at > 0)
    parts.push_back(zeros(b, loc, type.withShape(at, type.getCols())));
  parts.push_back(row);
  if (k - at - 1 > 0)
    parts.push_back(zeros(b, loc, type.withShape(k - at - 1, type.getCols())));
  return ConcatOp::create(b, loc, type.withShape(k, type.getCols()),
                          ConcatAxis::vertical, parts);
}

} // namespace

Value Differentiator::unitSeed(OpBuilder &b, Operation *leaf, int64_t local) {
  auto type = cast<MatrixType>(leaf->getResult(0).getType());
  SmallVector<double> rowMajor(type.getNumElements(), 0.0);
  rowMajor[(local % type.getRows()) * type.getCols() + local / type.getRows()] =
      1.0;
  return constantMatrix(b, leaf->getLoc(), type, rowMajor);
}

FailureOr<bool> Differentiator::curvatureFree(AttrOp energy) {
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(energy);
  if (failed(groups))
    return failure();
  // Linear in its parameters: the Jacobian's own Jacobian is zero.
  auto linear = [&](Operation *decl) -> FailureOr<bool> {
    auto computed = dyn_cast<AttrOp>(decl);
    if (!computed)
      return true;
    FailureOr<AttrOp> jac = jacobian(computed);
    if (failed(jac))
      return failure();
    if (!*jac)
      return true;
    FailureOr<AttrOp> second = jacobian(*jac);
    if (failed(second))
      return failure();
    return !*second;
  };
  for (const ParamGroup &g : *groups) {
    SmallVector<Operation *> sources;
    if (g.kind == GroupKind::Join)
      sources.push_back(g.base);
    if (g.kind == GroupKind::Union)
      for (Operation *member : cast<PrimitiveUnionOp>(g.key).getMemberOps())
        sources.push_back(tables.lookupSymbolIn(
            member, g.base->getAttrOfType<StringAttr>(
                        SymbolTable::getSymbolAttrName())));
    for (Operation *source : sources) {
      FailureOr<bool> isLinear = linear(source);
      if (failed(isLinear))
        return failure();
      if (!*isLinear)
        return false;
    }
  }
  return true;
}

FailureOr<AttrOp> Differentiator::innerMap(AttrOp energy) {
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(energy);
  if (failed(groups))
    return failure();
  int64_t n = 0, m = 0;
  for (const ParamGroup &g : *groups) {
    n += g.size();
    m += g.leafEntries;
  }
  MatrixType scalar = energy.getMatrixType();
  AttrOp map = createAttr(energy, (energy.getSymName() + "__ij").str(),
                          scalar.withShape(m, n), nullptr, ArrayAttr(),
                          DerivativeRole::ij);
  tables.invalidateSymbolTable(getOwningEntity(energy));
  IRMapping mapping;
  OpBuilder b = OpBuilder::atBlockEnd(&map.getBodyBlock());
  Location loc = energy.getLoc();
  for (Operation &op : energy.getBodyBlock().without_terminator())
    b.clone(op, mapping);
  SmallVector<std::pair<Operation *, const ParamGroup *>> leaves =
      leavesOf(map, *groups);
  // Column p: the seeds of parameter p at every leaf, flattened and stacked
  // in the order of the groups (the inner variables' order).
  SmallVector<Value> columns;
  for (const ParamGroup &g : *groups) {
    for (int64_t p = 0; p < g.size(); ++p) {
      SmallVector<Value> blocks;
      for (const ParamGroup &h : *groups) {
        MatrixType block = scalar.withShape(h.leafEntries, 1);
        Value value;
        if (&h == &g) {
          Operation *leaf = nullptr;
          for (auto [op, group] : leaves)
            if (group == &h && !leaf)
              leaf = op;
          FailureOr<Value> seeded = seed(b, leaf, g, p / g.width, p % g.width);
          if (failed(seeded))
            return failure();
          if (*seeded)
            value = ResizeOp::create(b, loc, block, *seeded);
        }
        blocks.push_back(value ? value : zeros(b, loc, block));
      }
      columns.push_back(blocks.size() == 1
                            ? blocks[0]
                            : ConcatOp::create(b, loc, scalar.withShape(m, 1),
                                               ConcatAxis::vertical, blocks)
                                  .getResult());
    }
  }
  Value result = columns.size() == 1
                     ? columns[0]
                     : ConcatOp::create(b, loc, scalar.withShape(m, n),
                                        ConcatAxis::horizontal, columns)
                           .getResult();
  YieldOp::create(b, loc, result);
  return map;
}

FailureOr<int64_t> Differentiator::paramCount(Operation *base) {
  if (auto it = counts.find(base); it != counts.end())
    return it->second;
  int64_t count = 0;
  if (auto attr = dyn_cast<AttrOp>(base)) {
    FailureOr<SmallVector<ParamGroup>> groups = groupsOf(attr);
    if (failed(groups))
      return failure();
    for (const ParamGroup &g : *groups)
      count += g.size();
  } else if (targets.contains(base)) {
    count = getAttributeType(base).getNumElements();
  }
  counts[base] = count;
  return count;
}

FailureOr<SmallVector<ParamGroup>> Differentiator::groupsOf(AttrOp attr,
                                                            bool inner) {
  SmallVector<ParamGroup> groups;
  auto add = [&](ParamGroup group) {
    for (const ParamGroup &g : groups)
      if (g.kind == group.kind && g.key == group.key && g.base == group.base)
        return;
    group.offset =
        groups.empty() ? 0 : groups.back().offset + groups.back().size();
    groups.push_back(group);
  };
  for (Operation &op : attr.getBodyBlock()) {
    if (auto read = dyn_cast<ReadOp>(op)) {
      Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
      if (isa<AttrOp>(decl) && !derivedFrom.count(decl))
        return read.emitOpError()
               << "reads " << ::mlir::yasps::describe(decl)
               << ": inline computed attributes (yasps-inline-reads) before "
                  "yasps-differentiate";
      Operation *base = baseOf(decl);
      if (!targets.contains(base))
        continue;
      int64_t rc = getAttributeType(base).getNumElements();
      add({GroupKind::Read, base, base, 1, rc, 0, rc});
    } else if (auto join = dyn_cast<JoinOp>(op)) {
      Operation *base = baseOf(lookupInScene(scene, join.getSource(), &tables));
      FailureOr<int64_t> width = paramCount(base);
      if (failed(width))
        return failure();
      if (*width == 0)
        continue;
      auto primitive = cast<PrimitiveOp>(getOwningEntity(attr));
      Operation *conn =
          tables.lookupSymbolIn(primitive, join.getConnectivityAttr());
      auto joinType = cast<MatrixType>(join.getType());
      add({GroupKind::Join, conn, base, joinType.getRows(), *width, 0,
           joinType.getNumElements()});
    } else if (auto unionOp = dyn_cast<UnionOp>(op)) {
      auto owner = cast<PrimitiveUnionOp>(getOwningEntity(attr));
      int64_t width = 0;
      Operation *base = nullptr;
      for (Operation *member : owner.getMemberOps()) {
        Operation *memberBase =
            baseOf(tables.lookupSymbolIn(member, unionOp.getNameAttr()));
        base = base ? base : memberBase;
        FailureOr<int64_t> count = paramCount(memberBase);
        if (failed(count))
          return failure();
        width = std::max(width, *count);
      }
      if (width == 0)
        continue;
      add({GroupKind::Union, owner, base, 1, width, 0,
           cast<MatrixType>(unionOp.getType()).getNumElements()});
    }
  }
  if (inner) {
    int64_t offset = 0;
    for (ParamGroup &g : groups) {
      g.count = 1;
      g.width = g.leafEntries;
      g.offset = offset;
      offset += g.width;
    }
  }
  return groups;
}

ArrayAttr Differentiator::describe(ArrayRef<ParamGroup> groups) {
  MLIRContext *ctx = scene.getContext();
  SmallVector<Attribute> out;
  for (const ParamGroup &g : groups) {
    for (int64_t slot = 0; slot < g.count; ++slot) {
      switch (g.kind) {
      case GroupKind::Read:
        out.push_back(ParamAttr::get(ctx, getScenePath(g.base)));
        break;
      case GroupKind::Join:
        out.push_back(ParamAttr::getJoin(
            FlatSymbolRefAttr::get(
                cast<ConnectivityOp>(g.key).getSymNameAttr()),
            slot, getScenePath(g.base), g.width));
        break;
      case GroupKind::Union:
        out.push_back(ParamAttr::getUnion(
            getScenePath(g.key),
            FlatSymbolRefAttr::get(g.base->getAttrOfType<StringAttr>(
                SymbolTable::getSymbolAttrName())),
            g.width));
        break;
      }
    }
  }
  return ArrayAttr::get(ctx, out);
}

AttrOp Differentiator::createAttr(AttrOp next, StringRef name, MatrixType type,
                                  Operation *derivedFromOp, ArrayAttr params,
                                  std::optional<DerivativeRole> role,
                                  Operation *of) {
  OpBuilder b(next->getBlock(), std::next(Block::iterator(next)));
  auto attr = AttrOp::create(b, next.getLoc(), b.getStringAttr(name),
                             TypeAttr::get(type));
  attr.getBody().push_back(new Block());
  if (params)
    attr->setAttr("yasps.params", params);
  if (role)
    attr->setAttr("yasps.derivative",
                  DerivativeAttr::get(b.getContext(), *role,
                                      getScenePath(of ? of : next)));
  if (derivedFromOp)
    derivedFrom[attr] = derivedFromOp;
  return attr;
}

FailureOr<Operation *> Differentiator::unionJacobian(Operation *member,
                                                     StringAttr name,
                                                     int64_t width) {
  std::string jacName =
      (name.getValue() + "__ujac" + std::to_string(width)).str();
  if (Operation *existing = tables.lookupSymbolIn(
          member, StringAttr::get(member->getContext(), jacName)))
    return existing;
  Operation *attr = tables.lookupSymbolIn(member, name);
  MatrixType type = getAttributeType(attr);
  int64_t rc = type.getNumElements();
  MatrixType jacType = type.withShape(rc, width);
  // Placed at the end of the member, after every attribute it may copy.
  OpBuilder anchor = OpBuilder::atBlockEnd(attr->getBlock());
  auto result =
      AttrOp::create(anchor, attr->getLoc(), anchor.getStringAttr(jacName),
                     TypeAttr::get(jacType));
  result.getBody().push_back(new Block());
  derivedFrom[result] = baseOf(attr);
  tables.invalidateSymbolTable(member);
  OpBuilder b = OpBuilder::atBlockEnd(&result.getBodyBlock());
  Location loc = attr->getLoc();
  Value value;
  Operation *base = baseOf(attr);
  // The member's attribute itself is differentiated (for a UNION of a
  // derivative, its Jacobian is the second derivative of the base).
  if (auto computed = dyn_cast<AttrOp>(attr)) {
    FailureOr<AttrOp> jac = jacobian(computed);
    if (failed(jac))
      return failure();
    if (!*jac) {
      value = zeros(b, loc, jacType);
      zeroUnionJacobians.insert(result);
    } else {
      // A copy of the member's Jacobian computation (not a read of it), so
      // that this attribute has the member's leaves and parameters and can
      // itself be differentiated.
      auto inner = (*jac).getMatrixType();
      IRMapping mapping;
      for (Operation &op : (*jac).getBodyBlock().without_terminator())
        b.clone(op, mapping);
      Value read = mapping.lookup(
          cast<YieldOp>((*jac).getBodyBlock().getTerminator()).getValue());
      value =
          inner.getCols() == width
              ? read
              : ConcatOp::create(
                    b, loc, jacType, ConcatAxis::horizontal,
                    ValueRange{read, zeros(b, loc,
                                           type.withShape(
                                               rc, width - inner.getCols()))});
    }
  } else {
    SmallVector<double> rowMajor(rc * width, 0.0);
    if (targets.contains(base))
      for (int64_t i = 0; i < rc; ++i)
        rowMajor[i * width + i] = 1.0;
    else
      zeroUnionJacobians.insert(result);
    value = constantMatrix(b, loc, jacType, rowMajor);
  }
  YieldOp::create(b, loc, value);
  return result.getOperation();
}

FailureOr<Value> Differentiator::seed(OpBuilder &b, Operation *leaf,
                                      const ParamGroup &group, int64_t slot,
                                      int64_t local) {
  Location loc = leaf->getLoc();
  auto type = cast<MatrixType>(leaf->getResult(0).getType());
  if (auto read = dyn_cast<ReadOp>(leaf)) {
    Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
    if (decl != group.base)
      return Value(); // a derivative of the target: constant in the target
    SmallVector<double> rowMajor(type.getNumElements(), 0.0);
    rowMajor[(local % type.getRows()) * type.getCols() +
             local / type.getRows()] = 1.0;
    return constantMatrix(b, loc, type, rowMajor);
  }
  if (auto join = dyn_cast<JoinOp>(leaf)) {
    Operation *source = lookupInScene(scene, join.getSource(), &tables);
    int64_t k = type.getRows(), rc = type.getCols();
    if (!isa<AttrOp>(source)) {
      // A stored target: unit entry in row `slot`.
      SmallVector<double> rowMajor(type.getNumElements(), 0.0);
      rowMajor[slot * rc + local] = 1.0;
      return constantMatrix(b, loc, type, rowMajor);
    }
    // Column `local` of the source's Jacobian at the gathered instance.
    Value &jj = gathered[leaf];
    if (!jj) {
      FailureOr<AttrOp> jac = jacobian(cast<AttrOp>(source));
      if (failed(jac))
        return failure();
      if (!*jac)
        return Value();
      int64_t width = (*jac).getMatrixType().getCols();
      OpBuilder::InsertionGuard guard(b);
      b.setInsertionPointAfter(leaf);
      jj = JoinOp::create(b, loc, type.withShape(k, rc * width),
                          join.getConnectivityAttr(), getScenePath(*jac));
    }
    auto jjType = cast<MatrixType>(jj.getType());
    if ((local + 1) * rc > jjType.getCols())
      return Value(); // padding beyond the source's parameters
    Value row =
        RowOp::create(b, loc, type.withShape(1, jjType.getCols()), jj, slot);
    Value column =
        SliceOp::create(b, loc, type.withShape(1, rc), row, 0, local * rc);
    return embedRow(b, loc, column, slot, k);
  }
  auto unionOp = cast<UnionOp>(leaf);
  Value &uj = gathered[leaf];
  if (!uj) {
    auto owner = cast<PrimitiveUnionOp>(getOwningEntity(leaf));
    Operation *first = nullptr;
    bool allZero = true;
    for (Operation *member : owner.getMemberOps()) {
      FailureOr<Operation *> jac =
          unionJacobian(member, unionOp.getNameAttr().getAttr(), group.width);
      if (failed(jac))
        return failure();
      first = first ? first : *jac;
      allZero &= zeroUnionJacobians.contains(*jac);
    }
    if (allZero)
      return Value(); // every member is constant in the parameters
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPointAfter(leaf);
    uj =
        UnionOp::create(b, loc, getAttributeType(first),
                        FlatSymbolRefAttr::get(first->getAttrOfType<StringAttr>(
                            SymbolTable::getSymbolAttrName())));
  }
  auto ujType = cast<MatrixType>(uj.getType());
  Value column =
      ColOp::create(b, loc, ujType.withShape(ujType.getRows(), 1), uj, local);
  return ResizeOp::create(b, loc, type, column).getResult();
}

SmallVector<std::pair<Operation *, const ParamGroup *>>
Differentiator::leavesOf(AttrOp jac, ArrayRef<ParamGroup> groups) {
  SmallVector<std::pair<Operation *, const ParamGroup *>> leaves;
  for (Operation &block : jac.getBodyBlock()) {
    Operation *op = &block;
    for (const ParamGroup &g : groups) {
      bool belongs = false;
      if (auto read = dyn_cast<ReadOp>(op))
        belongs = g.kind == GroupKind::Read &&
                  baseOf(lookupInScene(scene, read.getAttribute(), &tables)) ==
                      g.base;
      else if (auto join = dyn_cast<JoinOp>(op))
        belongs =
            g.kind == GroupKind::Join &&
            tables.lookupSymbolIn(getOwningEntity(jac),
                                  join.getConnectivityAttr()) == g.key &&
            baseOf(lookupInScene(scene, join.getSource(), &tables)) == g.base;
      else if (isa<UnionOp>(op))
        belongs = g.kind == GroupKind::Union;
      if (belongs)
        leaves.push_back({op, &g});
    }
  }
  return leaves;
}

FailureOr<AttrOp> Differentiator::jacobian(AttrOp attr, bool inner,
                                           bool symmetric) {
  auto memo = std::make_pair(attr.getOperation(), inner);
  if (auto it = jacobians.find(memo); it != jacobians.end())
    return it->second;
  FailureOr<SmallVector<ParamGroup>> groups = groupsOf(attr, inner);
  if (failed(groups))
    return failure();
  int64_t d =
      groups->empty() ? 0 : groups->back().offset + groups->back().size();
  if (d == 0) {
    jacobians[memo] = AttrOp();
    return AttrOp();
  }
  MatrixType type = attr.getMatrixType();
  int64_t rc = type.getNumElements();
  std::string name = (attr.getSymName() + (inner ? "__ijac" : "__jac")).str();
  Operation *entity = getOwningEntity(attr);
  if (tables.lookupSymbolIn(entity,
                            StringAttr::get(entity->getContext(), name)))
    return attr.emitOpError()
           << "cannot add its Jacobian @" << name << ": the name is taken";
  AttrOp jac =
      inner ? createAttr(attr, name, type.withShape(rc, d), attr, ArrayAttr())
            : createAttr(attr, name, type.withShape(rc, d), attr,
                         describe(*groups), DerivativeRole::jac);
  tables.invalidateSymbolTable(entity);
  jacobians[memo] = jac;

  // The attribute's own computation, then one tangent per parameter.
  IRMapping mapping;
  OpBuilder b = OpBuilder::atBlockEnd(&jac.getBodyBlock());
  for (Operation &op : attr.getBodyBlock().without_terminator())
    b.clone(op, mapping);
  Value root = mapping.lookup(
      cast<YieldOp>(attr.getBodyBlock().getTerminator()).getValue());
  SmallVector<std::pair<Operation *, const ParamGroup *>> leaves =
      leavesOf(jac, *groups);

  // A symmetric Jacobian (the Hessian: Jacobian of a gradient row whose
  // entries are separate values) needs entry i in direction p only for
  // i <= p; the rest is mirrored.
  SmallVector<Value> entries;
  if (auto concat = root.getDefiningOp<ConcatOp>();
      symmetric && concat && concat.getAxis() == ConcatAxis::horizontal &&
      rc == d && static_cast<int64_t>(concat.getInputs().size()) == d)
    entries.assign(concat.getInputs().begin(), concat.getInputs().end());
  SmallVector<Value> upper(d * d); // upper[i * d + p] = d(entry i)/d(p)
  SmallVector<Value> columns;
  bool anyNonZero = false;
  int64_t param = -1;
  for (const ParamGroup &g : *groups) {
    for (int64_t p = 0; p < g.size(); ++p) {
      ++param;
      int64_t slot = p / g.width, local = p % g.width;
      bool failedSeed = false;
      auto seedFn = [&](Operation *leaf) -> FailureOr<Value> {
        for (auto [op, group] : leaves)
          if (op == leaf && group == &g) {
            FailureOr<Value> s = inner ? unitSeed(b, leaf, local)
                                       : seed(b, leaf, g, slot, local);
            failedSeed |= failed(s);
            return s;
          }
        return Value();
      };
      Direction direction(b, seedFn);
      if (!entries.empty()) {
        for (int64_t i = 0; i <= param; ++i) {
          FailureOr<Value> t = direction.tangent(entries[i]);
          if (failed(t) || failedSeed)
            return failure();
          anyNonZero |= static_cast<bool>(*t);
          upper[i * d + param] = *t;
        }
        continue;
      }
      FailureOr<Value> t = direction.tangent(root);
      if (failed(t) || failedSeed)
        return failure();
      anyNonZero |= static_cast<bool>(*t);
      MatrixType column = type.withShape(rc, 1);
      columns.push_back(
          *t ? ResizeOp::create(b, attr.getLoc(), column, *t).getResult()
             : zeros(b, attr.getLoc(), column));
    }
  }
  if (!anyNonZero) {
    // Constant in its parameters (e.g. the Jacobian of a linear map): a
    // structural zero, so gathers of it and curvature terms disappear.
    jac.erase();
    derivedFrom.erase(jac);
    tables.invalidateSymbolTable(entity);
    jacobians[memo] = AttrOp();
    return AttrOp();
  }
  if (!entries.empty()) {
    MatrixType scalarType = type.withShape(1, 1);
    for (int64_t p = 0; p < d; ++p) {
      SmallVector<Value> column;
      for (int64_t i = 0; i < d; ++i) {
        Value v = upper[std::min(i, p) * d + std::max(i, p)];
        column.push_back(v ? v : zeros(b, attr.getLoc(), scalarType));
      }
      columns.push_back(ConcatOp::create(b, attr.getLoc(), type.withShape(d, 1),
                                         ConcatAxis::vertical, column));
    }
  }
  Value result = columns.size() == 1
                     ? columns[0]
                     : ConcatOp::create(b, attr.getLoc(), type.withShape(rc, d),
                                        ConcatAxis::horizontal, columns)
                           .getResult();
  YieldOp::create(b, attr.getLoc(), result);
  return jac;
}

namespace {
struct DifferentiatePass
    : public mlir::yasps::impl::YaspsDifferentiateBase<DifferentiatePass> {
  using YaspsDifferentiateBase::YaspsDifferentiateBase;
  void runOnOperation() override;
};
} // namespace

void DifferentiatePass::runOnOperation() {
  SymbolTableCollection tables;
  for (auto scene : getOperation().getOps<SceneOp>()) {
    auto minimize = scene.getBodyBlock().getOps<MinimizeOp>();
    if (minimize.empty())
      continue;
    DenseSet<Operation *> targets;
    for (auto ref :
         (*minimize.begin()).getTargets().getAsRange<SymbolRefAttr>())
      targets.insert(lookupInScene(scene, ref, &tables));
    Differentiator diff(scene, targets, tables);
    for (auto energy : scene.getBodyBlock().getOps<EnergyOp>()) {
      auto attr = dyn_cast_or_null<AttrOp>(
          lookupInScene(scene, energy.getAttribute(), &tables));
      if (!attr) {
        energy.emitOpError() << "energy " << energy.getAttribute()
                             << " is not a computed attribute; nothing to "
                                "differentiate";
        return signalPassFailure();
      }
      // Gradient = Jacobian of E (1 x d), transposed; Hessian = Jacobian of
      // the gradient's row.
      FailureOr<AttrOp> jac = diff.jacobian(attr);
      if (failed(jac))
        return signalPassFailure();
      if (!*jac)
        continue; // depends on no target
      FailureOr<AttrOp> hess =
          diff.jacobian(*jac, /*inner=*/false, /*symmetric=*/true);
      if (failed(hess))
        return signalPassFailure();
      MatrixType row = (*jac).getMatrixType();
      int64_t d = row.getCols();
      Attribute params = (*jac)->getAttr("yasps.params");
      auto alias = [&](StringRef suffix, DerivativeRole role, AttrOp of,
                       MatrixType type, bool transpose) -> AttrOp {
        AttrOp a =
            diff.createAttr(*jac, (attr.getSymName() + suffix).str(), type,
                            nullptr, cast<ArrayAttr>(params), role, attr);
        OpBuilder b = OpBuilder::atBlockEnd(&a.getBodyBlock());
        Value v =
            ReadOp::create(b, a.getLoc(), of.getMatrixType(), getScenePath(of));
        if (transpose)
          v = TransposeOp::create(b, a.getLoc(), type, v);
        else if (of.getMatrixType() != type)
          v = ResizeOp::create(b, a.getLoc(), type, v);
        YieldOp::create(b, a.getLoc(), v);
        return a;
      };
      MatrixType square = row.withShape(d, d);
      AttrOp hessAttr;
      if (*hess) {
        hessAttr = alias("__hess", DerivativeRole::hess, *hess, square, false);
      } else {
        hessAttr = diff.createAttr(*jac, (attr.getSymName() + "__hess").str(),
                                   square, nullptr, cast<ArrayAttr>(params),
                                   DerivativeRole::hess, attr);
        OpBuilder b = OpBuilder::atBlockEnd(&hessAttr.getBodyBlock());
        YieldOp::create(b, hessAttr.getLoc(),
                        zeros(b, hessAttr.getLoc(), square));
      }
      alias("__grad", DerivativeRole::grad, *jac, row.withShape(d, 1), true);
      // The PSD projection of the local Hessian, by the energy's method. In
      // reduced space (paper 5.4) when the parameterisations behind the
      // leaves are linear and the leaves have fewer entries than there are
      // parameters: J^T Project(H_inner) J, with H_inner the Hessian in the
      // leaf entries. Otherwise the full local Hessian is projected.
      FailureOr<bool> reducible = diff.curvatureFree(attr);
      FailureOr<SmallVector<ParamGroup>> groups = diff.groupsOf(attr);
      if (failed(reducible) || failed(groups))
        return signalPassFailure();
      int64_t m = 0;
      for (const ParamGroup &g : *groups)
        m += g.leafEntries;
      bool reduced = *reducible && m < d;
      bool separate = reduced && separateReducedHessians;
      AttrOp projected = diff.createAttr(
          *jac,
          (attr.getSymName() + (separate ? "__hess_inner_proj" : "__hess_proj"))
              .str(),
          separate ? row.withShape(m, m) : square, nullptr,
          cast<ArrayAttr>(params),
          separate ? DerivativeRole::hess_inner_proj
                   : DerivativeRole::hess_proj,
          attr);
      projected->setAttr("yasps.projection",
                         ProjectionKindAttr::get(
                             &getContext(), separate  ? ProjectionKind::separate
                                            : reduced ? ProjectionKind::reduced
                                                      : ProjectionKind::full));
      Location loc = projected.getLoc();
      if (reduced) {
        FailureOr<AttrOp> innerGrad = diff.jacobian(attr, /*inner=*/true);
        FailureOr<AttrOp> innerHess =
            succeeded(innerGrad) && *innerGrad
                ? diff.jacobian(*innerGrad, /*inner=*/true,
                                /*symmetric=*/true)
                : FailureOr<AttrOp>(AttrOp());
        FailureOr<AttrOp> map = diff.innerMap(attr);
        if (failed(innerGrad) || failed(innerHess) || failed(map))
          return signalPassFailure();
        OpBuilder pb = OpBuilder::atBlockEnd(&projected.getBodyBlock());
        MatrixType innerType = row.withShape(m, m);
        Value hi = *innerHess ? ReadOp::create(pb, loc, innerType,
                                               getScenePath(*innerHess))
                                    .getResult()
                              : zeros(pb, loc, innerType);
        Value pi = ProjectOp::create(pb, loc, energy.getProjection(), hi);
        if (separate) {
          // J (@E__ij) stays an attribute of its own; the runtime forms
          // J^T P J while it assembles.
          (*map)->setAttr("yasps.params", params);
          YieldOp::create(pb, loc, pi);
          tables.invalidateSymbolTable(getOwningEntity(attr));
          continue;
        }
        Value j =
            ReadOp::create(pb, loc, row.withShape(m, d), getScenePath(*map));
        Value jt = TransposeOp::create(pb, loc, row.withShape(d, m), j);
        Value pj = MatmulOp::create(pb, loc, row.withShape(m, d), pi, j);
        Value result = MatmulOp::create(pb, loc, square, jt, pj);
        YieldOp::create(pb, loc, result);
      } else {
        OpBuilder pb = OpBuilder::atBlockEnd(&projected.getBodyBlock());
        Value h = ReadOp::create(pb, loc, square, getScenePath(hessAttr));
        Value p = ProjectOp::create(pb, loc, energy.getProjection(), h);
        YieldOp::create(pb, loc, p);
      }
      tables.invalidateSymbolTable(getOwningEntity(attr));
    }
  }
}
