//===- NVVMToHost.cpp - NVVM-level GPU kernels callable on the host -------===//
//
// The stand-in driver runs the generated GPU kernels on machines without a
// GPU from the very IR that becomes their cubins: only NVPTX code
// generation and ptxas are left out. What a GPU thread reads from special
// registers it reads here from a ThreadContext the driver fills in, and
// what libdevice computes the host's math library computes (the same
// functions of the C standard: libdevice's are correctly rounded or within
// a few ulps, as glibc's are, so values agree to round-off, not bit for
// bit, where a kernel calls one).
//
//===----------------------------------------------------------------------===//

#include "yasps/Conversion/Passes.h"
#include "yasps/Runtime/Gpu/HostImage.h"

#include "mlir/Dialect/LLVMIR/NVVMDialect.h"
#include "mlir/IR/SymbolTable.h"

#include "llvm/ADT/StringSet.h"

namespace mlir::yasps {
#define GEN_PASS_DEF_YASPSNVVMTOHOST
#include "yasps/Conversion/Passes.h.inc"
} // namespace mlir::yasps

using namespace mlir;
namespace host_image = ::yasps::runtime::host_image;

namespace {

/// libdevice functions that generated kernels may call and that the C
/// math library has under the same name without `__nv_`.
const llvm::StringSet<> &libmNames() {
  static const llvm::StringSet<> names = [] {
    llvm::StringSet<> set;
    for (const char *name :
         {"sqrt",  "fabs",  "exp",   "exp2",  "expm1",    "log",  "log2",
          "log10", "log1p", "pow",   "sin",   "cos",      "tan",  "asin",
          "acos",  "atan",  "atan2", "sinh",  "cosh",     "tanh", "asinh",
          "acosh", "atanh", "cbrt",  "hypot", "fma",      "fmin", "fmax",
          "floor", "ceil",  "round", "trunc", "copysign", "erf",  "erfc",
          "fmod",  "rint"}) {
      set.insert(name);
      set.insert((llvm::Twine(name) + "f").str());
    }
    return set;
  }();
  return names;
}

/// The axis (0, 1, 2 for x, y, z) of a read of one register, or -1.
template <typename X, typename Y, typename Z> int64_t axisOf(Operation *op) {
  return isa<X>(op) ? 0 : isa<Y>(op) ? 1 : isa<Z>(op) ? 2 : -1;
}

/// The ThreadContext slot of a special register read, or -1.
int64_t slotOf(Operation *op) {
  using namespace NVVM;
  const std::pair<int64_t, int64_t> reads[] = {
      {host_image::kTid, axisOf<ThreadIdXOp, ThreadIdYOp, ThreadIdZOp>(op)},
      {host_image::kNtid, axisOf<BlockDimXOp, BlockDimYOp, BlockDimZOp>(op)},
      {host_image::kCtaid, axisOf<BlockIdXOp, BlockIdYOp, BlockIdZOp>(op)},
      {host_image::kNctaid, axisOf<GridDimXOp, GridDimYOp, GridDimZOp>(op)}};
  for (auto [slot, axis] : reads)
    if (axis >= 0)
      return slot + axis;
  return -1;
}

struct NVVMToHostPass
    : public mlir::yasps::impl::YaspsNVVMToHostBase<NVVMToHostPass> {
  void runOnOperation() override {
    gpu::GPUModuleOp module = getOperation();
    if (failed(checkHostable(module)) || failed(replaceLibdevice(module)))
      return signalPassFailure();
    SmallVector<LLVM::LLVMFuncOp> kernels;
    for (auto func : module.getOps<LLVM::LLVMFuncOp>())
      if (func->hasAttr(NVVM::NVVMDialect::getKernelFuncAttrName()))
        kernels.push_back(func);
    for (LLVM::LLVMFuncOp kernel : kernels)
      if (failed(makeHostKernel(kernel)))
        return signalPassFailure();
  }

  /// Fails on what the host cannot run.
  LogicalResult checkHostable(gpu::GPUModuleOp module) {
    WalkResult result = module.walk([&](Operation *op) -> WalkResult {
      if (auto global = dyn_cast<LLVM::GlobalOp>(op))
        if (global.getAddrSpace() != 0)
          return op->emitError("host images have no GPU shared or constant "
                               "memory"),
                 WalkResult::interrupt();
      if (auto asmOp = dyn_cast<LLVM::InlineAsmOp>(op))
        if (!isPreciseSqrt(asmOp))
          return op->emitError("inline assembly the host cannot run: ")
                     << asmOp.getAsmString(),
                 WalkResult::interrupt();
      if (isa<NVVM::NVVMDialect>(op->getDialect()) && slotOf(op) < 0)
        return op->emitError("no host equivalent of ") << op->getName(),
               WalkResult::interrupt();
      return WalkResult::advance();
    });
    if (result.wasInterrupted())
      return failure();
    module.walk([](LLVM::InlineAsmOp asmOp) {
      OpBuilder b(asmOp);
      Value root =
          LLVM::SqrtOp::create(b, asmOp.getLoc(), asmOp.getOperand(0).getType(),
                               asmOp.getOperand(0));
      asmOp.getResult(0).replaceAllUsesWith(root);
      asmOp.erase();
    });
    return success();
  }

  /// yasps-precise-gpu-sqrt's instruction: one f32 in, one out.
  static bool isPreciseSqrt(LLVM::InlineAsmOp op) {
    return op.getAsmString() == "sqrt.rn.f32 $0, $1;" &&
           op.getNumOperands() == 1 && op.getNumResults() == 1 &&
           op.getResult(0).getType().isF32();
  }

  /// Renames each libdevice declaration to its C counterpart.
  LogicalResult replaceLibdevice(gpu::GPUModuleOp module) {
    SymbolTable symbols(module);
    for (auto func :
         llvm::make_early_inc_range(module.getOps<LLVM::LLVMFuncOp>())) {
      StringRef name = func.getSymName();
      if (!name.consume_front("__nv_"))
        continue;
      if (!func.isExternal() || !libmNames().contains(name))
        return func.emitError("no host math function for ") << func.getName();
      if (failed(symbols.rename(func, name)))
        return func.emitError("cannot rename ")
               << func.getName() << " to " << name;
    }
    return success();
  }

  /// `@k` becomes `@k__body(args..., ptr thread)` and a new `@k(ptr params,
  /// ptr thread)` calls it with the parameters cuLaunchKernel passed.
  LogicalResult makeHostKernel(LLVM::LLVMFuncOp kernel) {
    MLIRContext *ctx = &getContext();
    Location loc = kernel.getLoc();
    auto ptr = LLVM::LLVMPointerType::get(ctx);
    auto i32 = IntegerType::get(ctx, 32);
    LLVM::LLVMFunctionType type = kernel.getFunctionType();
    if (type.isVarArg() || !isa<LLVM::LLVMVoidType>(type.getReturnType()))
      return kernel.emitError("a kernel returns nothing and is not variadic");
    std::string name = kernel.getSymName().str();
    SmallVector<Type> params(type.getParams());
    params.push_back(ptr);

    OpBuilder b(kernel);
    auto body = LLVM::LLVMFuncOp::create(
        b, loc, name + "__body",
        LLVM::LLVMFunctionType::get(type.getReturnType(), params),
        LLVM::Linkage::Internal);
    body.getBody().takeBody(kernel.getBody());
    Value thread = body.getBody().front().addArgument(ptr, loc);
    SmallVector<Operation *> reads;
    body.walk([&](Operation *op) {
      if (slotOf(op) >= 0)
        reads.push_back(op);
    });
    for (Operation *read : reads) {
      OpBuilder at(read);
      Value slot = LLVM::GEPOp::create(
          at, read->getLoc(), ptr, i32, thread,
          ArrayRef<LLVM::GEPArg>{static_cast<int32_t>(slotOf(read))},
          LLVM::GEPNoWrapFlags::inbounds);
      Value value = LLVM::LoadOp::create(at, read->getLoc(), i32, slot);
      read->getResult(0).replaceAllUsesWith(value);
      read->erase();
    }

    auto entry = LLVM::LLVMFuncOp::create(
        b, loc, name,
        LLVM::LLVMFunctionType::get(LLVM::LLVMVoidType::get(ctx), {ptr, ptr}));
    // Still the kernel that the host module's gpu.launch_func names.
    entry->setAttr(gpu::GPUDialect::getKernelFuncAttrName(), b.getUnitAttr());
    kernel.erase();
    Block *block = entry.addEntryBlock(b);
    b.setInsertionPointToStart(block);
    SmallVector<Value> args;
    for (auto [i, argType] : llvm::enumerate(type.getParams())) {
      Value slot =
          LLVM::GEPOp::create(b, loc, ptr, ptr, block->getArgument(0),
                              ArrayRef<LLVM::GEPArg>{static_cast<int32_t>(i)},
                              LLVM::GEPNoWrapFlags::inbounds);
      Value where = LLVM::LoadOp::create(b, loc, ptr, slot);
      args.push_back(LLVM::LoadOp::create(b, loc, argType, where));
    }
    args.push_back(block->getArgument(1));
    LLVM::CallOp::create(b, loc, body, args);
    LLVM::ReturnOp::create(b, loc, ValueRange{});
    return success();
  }
};

} // namespace
