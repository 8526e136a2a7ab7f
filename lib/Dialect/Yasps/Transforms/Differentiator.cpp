//===- Differentiator.cpp - forward-mode Jacobians of attributes ----------===//
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

#include "Differentiator.h"
#include "Direction.h"

#include "mlir/IR/IRMapping.h"

using namespace mlir;
using namespace mlir::yasps;
using namespace mlir::yasps::differentiation;

namespace {

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

Value mlir::yasps::differentiation::constantMatrix(OpBuilder &b, Location loc,
                                                   MatrixType type,
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

Value mlir::yasps::differentiation::zeros(OpBuilder &b, Location loc,
                                          MatrixType type) {
  return constantMatrix(b, loc, type,
                        SmallVector<double>(type.getNumElements(), 0.0));
}

Value Differentiator::unitSeed(OpBuilder &b, Operation *leaf, int64_t local) {
  auto type = cast<MatrixType>(leaf->getResult(0).getType());
  SmallVector<double> rowMajor(type.getNumElements(), 0.0);
  rowMajor[(local % type.getRows()) * type.getCols() + local / type.getRows()] =
      1.0;
  return constantMatrix(b, leaf->getLoc(), type, rowMajor);
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

LogicalResult differentiation::checkSize(Operation *at, StringRef name,
                                         MatrixType type) {
  // Rows and columns are checked first: the product cannot overflow.
  if (type.getRows() <= MatrixType::kMaxEntries &&
      type.getCols() <= MatrixType::kMaxEntries &&
      type.getNumElements() <= MatrixType::kMaxEntries)
    return success();
  return at->emitOpError()
         << "needs @" << name << " of " << type.getRows() << "x"
         << type.getCols() << " entries per instance, more than the "
         << MatrixType::kMaxEntries
         << " a yasps matrix may have: fewer local parameters (a smaller "
            "JOIN, narrower UNION members) or a reduced space (paper 5.4)";
}

FailureOr<AttrOp>
Differentiator::createAttr(AttrOp next, StringRef name, MatrixType type,
                           Operation *derivedFromOp, ArrayAttr params,
                           std::optional<DerivativeRole> role, Operation *of) {
  Operation *entity = getOwningEntity(next);
  SymbolTable &table = tables.getSymbolTable(entity);
  // The symbol table would rename it; a user's attribute of that name must
  // not pass for the derivative.
  if (table.lookup(name))
    return next.emitOpError()
           << "cannot add @" << name << ": the name is taken";
  if (failed(checkSize(next, name, type)))
    return failure();
  OpBuilder b(next.getContext());
  auto attr = AttrOp::create(b, next.getLoc(), b.getStringAttr(name),
                             TypeAttr::get(type));
  attr.getBody().push_back(new Block());
  table.insert(attr, std::next(Block::iterator(next)));
  if (params)
    attr->setAttr(kParamsAttr, params);
  if (role)
    attr->setAttr(kDerivativeAttr,
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
  if (failed(checkSize(attr, jacName, jacType)))
    return failure();
  OpBuilder detached(member->getContext());
  auto result =
      AttrOp::create(detached, attr->getLoc(), detached.getStringAttr(jacName),
                     TypeAttr::get(jacType));
  result.getBody().push_back(new Block());
  // Placed at the end of the member, after every attribute it may copy.
  tables.getSymbolTable(member).insert(result);
  derivedFrom[result] = baseOf(attr);
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
  FailureOr<AttrOp> created =
      inner ? createAttr(attr, name, type.withShape(rc, d), attr, ArrayAttr())
            : createAttr(attr, name, type.withShape(rc, d), attr,
                         describe(*groups), DerivativeRole::jac);
  if (failed(created))
    return failure();
  AttrOp jac = *created;
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
    derivedFrom.erase(jac);
    tables.getSymbolTable(entity).erase(jac);
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
