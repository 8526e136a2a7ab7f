//===- YaspsToLoops.cpp - per-instance loop kernels for attributes --------===//
//
// Each requested attribute becomes a function with one parallel loop over the
// instances of its owner. Inside the loop the attribute is evaluated by
// walking its definition: stored attributes are loaded, computed attributes
// are evaluated in place (nothing intermediate is materialised), JOINs gather
// through connectivity buffers and evaluate their source at the gathered
// instances, UNIONs decode the union index and evaluate the member's
// attribute in an scf.if chain.
//
// With `projection-lanes` W > 1, a kernel whose value goes through one PSD
// projection runs its instances in tiles of W: the body is emitted twice,
// once to store each instance's matrix to be projected into a scratch
// buffer and once to finish each instance with its projected matrix, and
// between them one eigen-decomposition works on all W matrices at once in
// vector lanes. The QL iteration is a chain of dependent square roots and
// divisions; lanes keep W chains in flight. What each copy of the body does
// not need is dead code that LLVM removes.
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/Passes.h"

#include "ImperativeBuilder.h"
#include "yasps/Conversion/YaspsToLoops/ScalarLowering.h"
#include "yasps/Dialect/Yasps/IR/Yasps.h"

#include "mlir/AsmParser/AsmParser.h"
#include "mlir/Dialect/Vector/IR/VectorOps.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSLOWERTOLOOPS
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {

/// Builds the body of one kernel function, adding buffer arguments to it as
/// the evaluation meets stored attributes, connectivities and unions.
class KernelEmitter {
public:
  KernelEmitter(SceneOp scene, SymbolTableCollection &tables, func::FuncOp func,
                bool symbolicZeros)
      : scene(scene), tables(tables), func(func), symbolicZeros(symbolicZeros) {
  }

  /// The buffer argument holding `symbol`'s data, created on first use.
  Value buffer(StringRef kind, Operation *symbol, Type elementType) {
    auto key = std::make_pair(kind, symbol);
    auto it = buffers.find(key);
    if (it != buffers.end())
      return it->second;
    Block &entry = func.getBody().front();
    Type type = MemRefType::get({ShapedType::kDynamic}, elementType);
    Value arg = entry.addArgument(type, symbol->getLoc());
    buffers[key] = arg;
    MLIRContext *ctx = func.getContext();
    // Scene-wide buffers (the DoF offsets of targets) name the scene.
    Attribute path = isa<SceneOp>(symbol)
                         ? Attribute(FlatSymbolRefAttr::get(
                               ctx, cast<SceneOp>(symbol).getSymName()))
                         : Attribute(getScenePath(symbol));
    roles.push_back(ArrayAttr::get(ctx, {StringAttr::get(ctx, kind), path}));
    return arg;
  }

  /// The value of the attribute declared by `decl` at instance `index`.
  FailureOr<ScalarMatrix> evaluate(OpBuilder &b, Operation *decl, Value index) {
    for (auto &scope : llvm::reverse(scopes))
      if (auto it = scope.find({decl, index}); it != scope.end())
        return it->second;
    FailureOr<ScalarMatrix> result = failure();
    if (auto computed = dyn_cast<AttrOp>(decl))
      result = evaluateComputed(b, computed, index);
    else
      result = load(b, decl, index);
    if (succeeded(result))
      scopes.back()[{decl, index}] = *result;
    return result;
  }

  void store(OpBuilder &b, Value out, const ScalarMatrix &value, Value index) {
    Location loc = func.getLoc();
    Value base = offset(b, index, value.values.size());
    for (auto [i, scalar] : llvm::enumerate(value.values))
      memref::StoreOp::create(b, loc, scalar, out, ValueRange{add(b, base, i)});
  }

  ArrayAttr getRoles() { return ArrayAttr::get(func.getContext(), roles); }

  /// Forgets computed values (before emitting the body again elsewhere).
  void resetScopes() {
    scopes.clear();
    scopes.emplace_back();
  }

  /// When set, lowers `yasps.project` instead of the scalar eigensolver
  /// (returning std::nullopt leaves it to the scalar lowering).
  std::function<std::optional<ScalarMatrix>(OpBuilder &, ProjectOp,
                                            const ScalarMatrix &)>
      projectHook;

private:
  Value constIndex(OpBuilder &b, int64_t value) {
    return arith::ConstantIndexOp::create(b, func.getLoc(), value);
  }
  Value add(OpBuilder &b, Value base, int64_t value) {
    if (value == 0)
      return base;
    return arith::AddIOp::create(b, func.getLoc(), base, constIndex(b, value));
  }
  Value offset(OpBuilder &b, Value index, int64_t stride) {
    if (stride == 1)
      return index;
    return arith::MulIOp::create(b, func.getLoc(), index,
                                 constIndex(b, stride));
  }

  /// Entries of a stored attribute, read from its buffer.
  FailureOr<ScalarMatrix> load(OpBuilder &b, Operation *decl, Value index) {
    MatrixType type = getAttributeType(decl);
    Value data = buffer("attr", decl, type.getElementType());
    Value base = offset(b, index, type.getNumElements());
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    for (int64_t i = 0; i < type.getNumElements(); ++i)
      out.values.push_back(memref::LoadOp::create(b, decl->getLoc(), data,
                                                  ValueRange{add(b, base, i)}));
    return out;
  }

  FailureOr<ScalarMatrix> evaluateComputed(OpBuilder &b, AttrOp attr,
                                           Value index) {
    Operation *owner = getOwningEntity(attr);
    DenseMap<Value, ScalarMatrix> values;
    for (Operation &op : attr.getBodyBlock()) {
      if (auto yield = dyn_cast<YieldOp>(op))
        return values.lookup(yield.getValue());
      FailureOr<ScalarMatrix> result = failure();
      if (auto read = dyn_cast<ReadOp>(op)) {
        Operation *decl = lookupInScene(scene, read.getAttribute(), &tables);
        // Scene and mesh attributes have one instance: a broadcast.
        Value at = getOwningEntity(decl) == owner ? index : constIndex(b, 0);
        result = evaluate(b, decl, at);
      } else if (auto dof = dyn_cast<DofIndexOp>(op)) {
        result = dofNumbers(b, dof, owner, index);
      } else if (auto join = dyn_cast<JoinOp>(op)) {
        result = evaluateJoin(b, join, index);
      } else if (auto unionOp = dyn_cast<UnionOp>(op)) {
        result = evaluateUnion(b, cast<PrimitiveUnionOp>(owner),
                               unionOp.getNameAttr(),
                               cast<MatrixType>(unionOp.getType()), index);
      } else {
        SmallVector<ScalarMatrix> operands;
        for (Value operand : op.getOperands())
          operands.push_back(values.lookup(operand));
        std::optional<ScalarMatrix> hooked;
        if (auto project = dyn_cast<ProjectOp>(op); project && projectHook)
          hooked = projectHook(b, project, operands.front());
        result = hooked ? FailureOr<ScalarMatrix>(*hooked)
                        : lowerToScalars(b, &op, operands, symbolicZeros);
      }
      if (failed(result))
        return failure();
      values[op.getResult(0)] = *result;
    }
    llvm_unreachable("verified attribute regions end in yasps.yield");
  }

  /// offset(T) + i*rc + e + 1 for the entries e of target T at instance i;
  /// the targets' offsets come in the "dof_offsets" buffer (i64, one per
  /// target of yasps.minimize, in order).
  FailureOr<ScalarMatrix> dofNumbers(OpBuilder &b, DofIndexOp dof,
                                     Operation *owner, Value index) {
    Location loc = dof.getLoc();
    Operation *decl = lookupInScene(scene, dof.getTarget(), &tables);
    int64_t position = -1, k = 0;
    for (auto minimize : scene.getBodyBlock().getOps<MinimizeOp>())
      for (auto target : minimize.getTargets().getAsRange<SymbolRefAttr>()) {
        if (position < 0 && lookupInScene(scene, target, &tables) == decl)
          position = k;
        ++k;
      }
    if (position < 0)
      return dof.emitOpError() << "names no minimisation target";
    Value offsets = buffer("dof_offsets", scene, b.getI64Type());
    Value raw = memref::LoadOp::create(b, loc, offsets,
                                       ValueRange{constIndex(b, position)});
    Value first = arith::IndexCastOp::create(b, loc, b.getIndexType(), raw);
    Value at = getOwningEntity(decl) == owner ? index : constIndex(b, 0);
    MatrixType type = dof.getMatrixType();
    int64_t entries = type.getNumElements();
    Value base = arith::AddIOp::create(b, loc, first, offset(b, at, entries));
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    for (int64_t e = 0; e < entries; ++e) {
      Value number = arith::IndexCastOp::create(b, loc, b.getI64Type(),
                                                add(b, base, e + 1));
      out.values.push_back(
          arith::SIToFPOp::create(b, loc, type.getElementType(), number));
    }
    return out;
  }

  /// Row l of the result is the source at the l-th connected instance.
  FailureOr<ScalarMatrix> evaluateJoin(OpBuilder &b, JoinOp join, Value index) {
    Location loc = join.getLoc();
    auto primitive = cast<PrimitiveOp>(getOwningEntity(join));
    auto connectivity = cast<ConnectivityOp>(
        tables.lookupSymbolIn(primitive, join.getConnectivityAttr()));
    Operation *source = lookupInScene(scene, join.getSource(), &tables);
    int64_t arity = connectivity.getArity();
    Value indices = buffer("conn", connectivity, b.getI32Type());
    Value base = offset(b, index, arity);
    auto type = cast<MatrixType>(join.getType());
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    out.values.resize(type.getNumElements());
    for (int64_t l = 0; l < arity; ++l) {
      Value raw =
          memref::LoadOp::create(b, loc, indices, ValueRange{add(b, base, l)});
      Value target = arith::IndexCastOp::create(b, loc, b.getIndexType(), raw);
      FailureOr<ScalarMatrix> row = evaluate(b, source, target);
      if (failed(row))
        return failure();
      for (auto [m, scalar] : llvm::enumerate(row->values))
        out.values[m * arity + l] = scalar;
    }
    return out;
  }

  /// Finds the member that `index` falls in and evaluates its attribute.
  FailureOr<ScalarMatrix> evaluateUnion(OpBuilder &b, PrimitiveUnionOp owner,
                                        FlatSymbolRefAttr name, MatrixType type,
                                        Value index) {
    Location loc = owner.getLoc();
    Value offsets = buffer("offsets", owner, b.getI64Type());
    SmallVector<Operation *> members = owner.getMemberOps();
    auto offsetOf = [&](OpBuilder &ib, int64_t member) -> Value {
      Value raw = memref::LoadOp::create(ib, loc, offsets,
                                         ValueRange{constIndex(ib, member)});
      return arith::IndexCastOp::create(ib, loc, ib.getIndexType(), raw);
    };
    auto evaluateMember = [&](OpBuilder &ib,
                              size_t member) -> FailureOr<ScalarMatrix> {
      Operation *decl = tables.lookupSymbolIn(members[member], name);
      Value local = arith::SubIOp::create(ib, loc, index, offsetOf(ib, member));
      return evaluate(ib, decl, local);
    };
    return chain(b, loc, type, 0, members.size(), offsetOf, evaluateMember,
                 index);
  }

  /// scf.if chain: member m when index < offsets[m+1], else the rest.
  template <typename OffsetFn, typename MemberFn>
  FailureOr<ScalarMatrix> chain(OpBuilder &b, Location loc, MatrixType type,
                                size_t member, size_t numMembers,
                                OffsetFn offsetOf, MemberFn evaluateMember,
                                Value index) {
    if (member + 1 == numMembers)
      return evaluateMember(b, member);
    Value inMember = arith::CmpIOp::create(b, loc, arith::CmpIPredicate::ult,
                                           index, offsetOf(b, member + 1));
    SmallVector<Type> resultTypes(type.getNumElements(), type.getElementType());
    auto ifOp = scf::IfOp::create(b, loc, resultTypes, inMember,
                                  /*withElseRegion=*/true);
    for (int branch = 0; branch < 2; ++branch) {
      Block *block = branch == 0 ? ifOp.thenBlock() : ifOp.elseBlock();
      OpBuilder inner = OpBuilder::atBlockEnd(block);
      scopes.emplace_back();
      FailureOr<ScalarMatrix> value =
          branch == 0 ? evaluateMember(inner, member)
                      : chain(inner, loc, type, member + 1, numMembers,
                              offsetOf, evaluateMember, index);
      scopes.pop_back();
      if (failed(value))
        return failure();
      scf::YieldOp::create(inner, loc, value->values);
    }
    ScalarMatrix out{type.getRows(), type.getCols(), {}};
    out.values.append(ifOp.getResults().begin(), ifOp.getResults().end());
    return out;
  }

  SceneOp scene;
  SymbolTableCollection &tables;
  func::FuncOp func;
  bool symbolicZeros;
  std::map<std::pair<StringRef, Operation *>, Value> buffers;
  SmallVector<Attribute> roles;
  /// Values already computed, per region: an inner region may reuse the
  /// values of enclosing ones but not those of its siblings.
  SmallVector<DenseMap<std::pair<Operation *, Value>, ScalarMatrix>> scopes{1};
};

enum class Batching { Done, NotApplicable, Failed };

/// Emits into `loop` (a parallel loop over tiles of `lanes` instances) the
/// lane-batched kernel body described at the top of this file.
/// NotApplicable, with the loop left to be erased, when the value does not
/// go through exactly one projection at the top level of the body; Failed
/// when evaluation reported an error.
Batching emitBatchedProjection(KernelEmitter &emitter, Operation *decl,
                               Value out, scf::ParallelOp loop, Value end,
                               int64_t lanes) {
  Location loc = decl->getLoc();
  OpBuilder b = OpBuilder::atBlockTerminator(loop.getBody());
  Value tile = loop.getInductionVars()[0];
  Value zero = arith::ConstantIndexOp::create(b, loc, 0);
  Value one = arith::ConstantIndexOp::create(b, loc, 1);
  Value count = arith::MinUIOp::create(
      b, loc, arith::ConstantIndexOp::create(b, loc, lanes),
      arith::SubIOp::create(b, loc, end, tile));
  auto type = cast<FloatType>(getAttributeType(decl).getElementType());
  auto laneType = VectorType::get({lanes}, type);
  // Scratch of the matrices before and after projection, lanes innermost.
  Value before, after;
  int64_t entries = 0;
  std::optional<ProjectionMethod> method;
  int64_t projections = 0;
  Block *laneBody = nullptr;
  Operation *laneLoopOp = nullptr;
  Value lane;
  auto laneLoop = [&](auto body) {
    auto forOp = scf::ForOp::create(b, loc, zero, count, one);
    OpBuilder inner = OpBuilder::atBlockTerminator(forOp.getBody());
    laneBody = forOp.getBody();
    laneLoopOp = forOp;
    lane = forOp.getInductionVar();
    return body(inner, arith::AddIOp::create(inner, loc, tile, lane));
  };

  // 1. Every instance stores the matrix it projects.
  emitter.resetScopes();
  emitter.projectHook =
      [&](OpBuilder &ib, ProjectOp project,
          const ScalarMatrix &in) -> std::optional<ScalarMatrix> {
    if (project.getMethod() == ProjectionMethod::none)
      return std::nullopt;
    // Only one projection, evaluated once per instance, is batched.
    if (projections++ > 0 || ib.getInsertionBlock() != laneBody)
      return std::nullopt;
    method = project.getMethod();
    entries = in.values.size();
    ImperativeBuilder alloc{ib, loc, type, lanes};
    before = alloc.buffer({entries});
    after = alloc.buffer({entries});
    for (auto [k, v] : llvm::enumerate(in.values))
      memref::StoreOp::create(
          ib, loc, v, before,
          ValueRange{arith::ConstantIndexOp::create(ib, loc, k), lane});
    ScalarMatrix zeros{in.rows, in.cols, {}};
    Value zeroValue =
        arith::ConstantOp::create(ib, loc, ib.getFloatAttr(type, 0));
    zeros.values.assign(entries, zeroValue);
    return zeros;
  };
  bool evaluated = laneLoop([&](OpBuilder &inner, Value instance) {
    return succeeded(emitter.evaluate(inner, decl, instance));
  });
  emitter.projectHook = nullptr;
  if (!evaluated)
    return Batching::Failed;
  if (projections != 1 || !method)
    return Batching::NotApplicable;
  {
    // Lanes past the end of the last tile project zeros (cheap, and never
    // uninitialised memory).
    OpBuilder::InsertionGuard guard(b);
    b.setInsertionPoint(laneLoopOp);
    Value zeros = arith::ConstantOp::create(
        b, loc, DenseElementsAttr::get(laneType, b.getFloatAttr(type, 0)));
    for (int64_t k = 0; k < entries; ++k)
      vector::StoreOp::create(
          b, loc, zeros, before,
          ValueRange{arith::ConstantIndexOp::create(b, loc, k), zero});
  }

  // 2. One projection of all lanes.
  int64_t n = 0;
  while (n * n < entries)
    ++n;
  ScalarMatrix lanesIn{n, n, {}};
  for (int64_t k = 0; k < entries; ++k)
    lanesIn.values.push_back(vector::LoadOp::create(
        b, loc, laneType, before,
        ValueRange{arith::ConstantIndexOp::create(b, loc, k), zero}));
  ScalarMatrix projected = lowerProjection(b, loc, *method, lanesIn);
  for (auto [k, v] : llvm::enumerate(projected.values))
    vector::StoreOp::create(
        b, loc, v, after,
        ValueRange{arith::ConstantIndexOp::create(b, loc, k), zero});

  // 3. Every instance finishes with its projected matrix.
  emitter.resetScopes();
  emitter.projectHook =
      [&](OpBuilder &ib, ProjectOp project,
          const ScalarMatrix &in) -> std::optional<ScalarMatrix> {
    if (project.getMethod() == ProjectionMethod::none)
      return std::nullopt;
    ScalarMatrix result{in.rows, in.cols, {}};
    for (int64_t k = 0; k < entries; ++k)
      result.values.push_back(memref::LoadOp::create(
          ib, loc, after,
          ValueRange{arith::ConstantIndexOp::create(ib, loc, k), lane}));
    return result;
  };
  bool finished = laneLoop([&](OpBuilder &inner, Value instance) {
    FailureOr<ScalarMatrix> value = emitter.evaluate(inner, decl, instance);
    if (failed(value))
      return false;
    emitter.store(inner, out, *value, instance);
    return true;
  });
  emitter.projectHook = nullptr;
  emitter.resetScopes();
  return finished ? Batching::Done : Batching::Failed;
}

std::string kernelName(SymbolRefAttr path) {
  std::string name = "yasps_eval_" + path.getRootReference().str();
  for (FlatSymbolRefAttr nested : path.getNestedReferences())
    name += "__" + nested.getValue().str();
  return name;
}

struct LowerToLoopsPass
    : public mlir::yasps::impl::YaspsLowerToLoopsBase<LowerToLoopsPass> {
  using YaspsLowerToLoopsBase::YaspsLowerToLoopsBase;

  void runOnOperation() override;
  LogicalResult lowerAttribute(SceneOp scene, SymbolTableCollection &tables,
                               SymbolRefAttr path);
};

} // namespace

LogicalResult LowerToLoopsPass::lowerAttribute(SceneOp scene,
                                               SymbolTableCollection &tables,
                                               SymbolRefAttr path) {
  ModuleOp module = getOperation();
  Operation *decl = lookupInScene(scene, path, &tables);
  if (!isAttributeDecl(decl))
    return scene.emitError()
           << "yasps-lower-to-loops: " << path
           << " does not name an attribute of scene @" << scene.getSymName();
  MatrixType type = getAttributeType(decl);
  Location loc = decl->getLoc();
  std::string name = kernelName(path);
  if (SymbolTable::lookupSymbolIn(module, name))
    return decl->emitError() << "kernel @" << name << " already exists";

  OpBuilder builder = OpBuilder::atBlockEnd(module.getBody());
  Type indexType = builder.getIndexType();
  auto func = func::FuncOp::create(
      builder, loc, name, builder.getFunctionType({indexType, indexType}, {}));
  Block *entry = func.addEntryBlock();
  OpBuilder b = OpBuilder::atBlockBegin(entry);

  // Derivative attributes (from yasps-differentiate) get symbolic zeros.
  KernelEmitter emitter(scene, tables, func,
                        /*symbolicZeros=*/decl->hasAttr("yasps.params"));
  Value out = emitter.buffer("out", decl, type.getElementType());
  Value one = arith::ConstantIndexOp::create(b, loc, 1);
  auto ret = func::ReturnOp::create(b, loc);
  b.setInsertionPoint(ret);
  // The loop is created first and filled afterwards so that code generated
  // for the body can reach the enclosing function (e.g. for scratch buffers).
  bool batched = false;
  if (projectionLanes > 1) {
    Value lanes = arith::ConstantIndexOp::create(b, loc, projectionLanes);
    auto loop = scf::ParallelOp::create(
        b, loc, ValueRange{entry->getArgument(0)},
        ValueRange{entry->getArgument(1)}, ValueRange{lanes});
    Batching result = emitBatchedProjection(
        emitter, decl, out, loop, entry->getArgument(1), projectionLanes);
    if (result == Batching::Failed)
      return failure();
    batched = result == Batching::Done;
    if (!batched) {
      loop.erase();
      emitter.resetScopes();
    }
  }
  if (!batched) {
    auto loop = scf::ParallelOp::create(
        b, loc, ValueRange{entry->getArgument(0)},
        ValueRange{entry->getArgument(1)}, ValueRange{one});
    OpBuilder body = OpBuilder::atBlockTerminator(loop.getBody());
    Value instance = loop.getInductionVars()[0];
    FailureOr<ScalarMatrix> value = emitter.evaluate(body, decl, instance);
    if (failed(value))
      return failure();
    emitter.store(body, out, *value, instance);
  }

  func.setType(builder.getFunctionType(entry->getArgumentTypes(), {}));
  func->setAttr("yasps.kernel_of", path);
  func->setAttr("yasps.kernel_args", emitter.getRoles());
  // Rows and columns of each instance's value in `out`.
  func->setAttr("yasps.kernel_shape",
                builder.getDenseI64ArrayAttr({type.getRows(), type.getCols()}));
  // Derivative attributes describe their local parameters; keep that with
  // the kernel for the runtime.
  if (Attribute params = decl->getAttr("yasps.params"))
    func->setAttr("yasps.params", params);
  // And projected Hessians how they are projected (full, reduced, ...).
  if (Attribute projection = decl->getAttr("yasps.projection"))
    func->setAttr("yasps.projection", projection);
  return success();
}

void LowerToLoopsPass::runOnOperation() {
  ModuleOp module = getOperation();
  SmallVector<SceneOp> scenes = llvm::to_vector(module.getOps<SceneOp>());
  SceneOp scene;
  for (SceneOp candidate : scenes)
    if (sceneName.empty() || candidate.getSymName() == sceneName)
      scene = candidate;
  if (!scene || (sceneName.empty() && scenes.size() != 1)) {
    module.emitError() << "yasps-lower-to-loops: "
                       << (sceneName.empty()
                               ? "the module must hold exactly one scene "
                                 "(or name one with scene=)"
                               : "no scene @" + sceneName);
    return signalPassFailure();
  }

  SmallVector<SymbolRefAttr> paths;
  for (const std::string &text : attributes) {
    auto path =
        dyn_cast_or_null<SymbolRefAttr>(parseAttribute(text, &getContext()));
    if (!path) {
      module.emitError() << "yasps-lower-to-loops: '" << text
                         << "' is not a symbol path like @mesh::@prim::@attr";
      return signalPassFailure();
    }
    paths.push_back(path);
  }
  if (attributes.empty())
    for (auto energy : scene.getBodyBlock().getOps<EnergyOp>())
      paths.push_back(energy.getAttribute());

  SymbolTableCollection tables;
  for (SymbolRefAttr path : paths)
    if (failed(lowerAttribute(scene, tables, path)))
      return signalPassFailure();
}
