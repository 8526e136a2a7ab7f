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
// KernelEmitter.h emits the body of one instance; LaneBatch.h the body of a
// tile of instances in SIMD lanes (CPU kernels).
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/Passes.h"

#include "KernelEmitter.h"
#include "LaneBatch.h"

#include "mlir/AsmParser/AsmParser.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSLOWERTOLOOPS
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
using namespace mlir::yasps;

namespace {

// Projections up to this size get projectionLanes: measured on 9x9 and
// 12x12 (stable Neo-Hookean, 16 against 8 lanes: 1330 -> 1100 and 1936 ->
// 1661 ns per instance). 12x12 ones gained less for twice the straight-line
// code (1.1 s of the README demo's 11.5 s cold compile): from 10x10 up,
// kernels keep their compile time.
constexpr int64_t kMaxWideProjection = 9;

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
  /// The lanes of `attr`'s kernel: projectionLanes where it projects a
  /// matrix of at most kMaxWideProjection rows, else lanes.
  int64_t lanesOf(AttrOp attr) {
    if (projectionLanes <= 0 || lanes <= 1)
      return lanes;
    bool projects = false;
    attr.getBodyBlock().walk([&](ProjectOp project) {
      projects |= project.getMethod() != ProjectionMethod::none &&
                  project.getMatrixType().getRows() <= kMaxWideProjection;
    });
    return projects ? projectionLanes : lanes;
  }
  LogicalResult lowerAttribute(SceneOp scene, SymbolTableCollection &tables,
                               SymbolRefAttr path);
  /// The float types of attribute buffers (the `storage` option) and of
  /// output buffers (`out-storage`); null: the attribute's own type.
  FloatType attrStorage, outStorage;
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
                        /*symbolicZeros=*/decl->hasAttr(kParamsAttr),
                        attrStorage, outStorage);
  Value out = emitter.buffer(KernelArgKind::out, decl, type.getElementType());
  Value one = arith::ConstantIndexOp::create(b, loc, 1);
  auto ret = func::ReturnOp::create(b, loc);
  b.setInsertionPoint(ret);
  // The loop is created first and filled afterwards so that code generated
  // for the body can reach the enclosing function (e.g. for scratch buffers).
  bool batched = false;
  auto computed = dyn_cast<AttrOp>(decl);
  const int64_t width = computed ? lanesOf(computed) : 1;
  if (width > 1 && computed) {
    Value step = arith::ConstantIndexOp::create(b, loc, width);
    auto loop = scf::ParallelOp::create(
        b, loc, ValueRange{entry->getArgument(0)},
        ValueRange{entry->getArgument(1)}, ValueRange{step});
    // A region that cannot run in lanes (an op the lowering rejects) is
    // emitted one instance at a time below, which reports the error.
    {
      ScopedDiagnosticHandler quiet(&getContext(),
                                    [](Diagnostic &) { return success(); });
      LaneBatch batch(emitter, computed, width);
      batched = succeeded(batch.emit(loop, out, entry->getArgument(1))) &&
                batch.worthwhile(loop);
    }
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
  func->setAttr(kKernelOfAttr, path);
  func->setAttr(kKernelArgsAttr, emitter.getRoles());
  // Rows and columns of each instance's value in `out`.
  func->setAttr(kKernelShapeAttr,
                builder.getDenseI64ArrayAttr({type.getRows(), type.getCols()}));
  // Derivative attributes describe their local parameters; keep that with
  // the kernel for the runtime.
  if (Attribute params = decl->getAttr(kParamsAttr))
    func->setAttr(kParamsAttr, params);
  // And projected Hessians how they are projected (full, reduced, ...).
  if (Attribute projection = decl->getAttr(kProjectionAttr))
    func->setAttr(kProjectionAttr, projection);
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

  auto parseStorage = [&](StringRef option, StringRef value, FloatType &type) {
    if (value == "f32")
      type = Float32Type::get(&getContext());
    else if (value == "f64")
      type = Float64Type::get(&getContext());
    else if (!value.empty()) {
      module.emitError() << "yasps-lower-to-loops: " << option << "='" << value
                         << "' is not f32 or f64";
      return false;
    }
    return true;
  };
  if (!parseStorage("storage", storage, attrStorage) ||
      !parseStorage("out-storage", outStorage_, outStorage))
    return signalPassFailure();

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
