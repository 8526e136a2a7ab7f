//===- KernelGeneration.cpp - loop kernels shared by every target ---------===//

#include "yasps/Target/KernelGeneration.h"

#include "yasps/Conversion/Passes.h"
#include "yasps/Dialect/Yasps/Transforms/Passes.h"

#include "mlir/AsmParser/AsmParser.h"
#include "mlir/Dialect/Func/IR/FuncOps.h"
#include "mlir/IR/Verifier.h"
#include "mlir/Pass/PassRegistry.h"
#include "mlir/Transforms/Passes.h"
#include "llvm/Support/FileSystem.h"
#include "llvm/Support/SHA256.h"

#include <unistd.h>

using namespace mlir;
using namespace mlir::yasps;

char MissingAttributeError::ID;

void MissingAttributeError::log(llvm::raw_ostream &os) const {
  os << symbol << " does not name an attribute of scene @" << scene;
}

std::error_code MissingAttributeError::convertToErrorCode() const {
  return llvm::inconvertibleErrorCode();
}

/// `attr` printed without its dialect wrapper: "@m::@v::@x".
static std::string print(Attribute attr) {
  std::string text;
  llvm::raw_string_ostream(text) << attr;
  return text;
}

std::vector<std::vector<std::string>>
mlir::yasps::describeParams(ArrayAttr params) {
  std::vector<std::vector<std::string>> out;
  if (!params)
    return out;
  for (auto param : params.getAsRange<ParamAttr>()) {
    std::string kind = stringifyParamKind(param.getKind()).str();
    std::string width = std::to_string(param.getWidth());
    switch (param.getKind()) {
    case ParamKind::read:
      out.push_back({kind, print(param.getPath())});
      break;
    case ParamKind::join:
      out.push_back({kind, print(param.getVia()),
                     std::to_string(param.getSlot()), print(param.getPath()),
                     width});
      break;
    case ParamKind::union_:
      out.push_back({kind, print(param.getPath()),
                     param.getVia().getValue().str(), width});
      break;
    }
  }
  return out;
}

llvm::Error mlir::yasps::runPasses(
    ModuleOp module, const std::string &what,
    llvm::function_ref<LogicalResult(PassManager &)> populate,
    Verification verification) {
  std::string diagnostics;
  llvm::raw_string_ostream os(diagnostics);
  ScopedDiagnosticHandler handler(module.getContext(), [&](Diagnostic &diag) {
    os << diag.getLocation() << ": " << diag << "\n";
    for (Diagnostic &note : diag.getNotes())
      os << "  note: " << note << "\n";
    return success();
  });
  PassManager pm(module.getContext());
  pm.enableVerifier(verification == Verification::EachPass);
  if (failed(populate(pm)) || failed(pm.run(module)) ||
      (verification == Verification::AtEnd && failed(verify(module))))
    return llvm::createStringError(llvm::inconvertibleErrorCode(),
                                   what + (diagnostics.empty() ? "" : ":\n") +
                                       diagnostics);
  return llvm::Error::success();
}

/// A MissingAttributeError for the first of `attributes` that `module`'s
/// scene does not declare. Paths that do not parse, and modules without
/// exactly one scene, are left to yasps-lower-to-loops to report.
static llvm::Error
checkAttributesExist(ModuleOp module,
                     const std::vector<std::string> &attributes) {
  auto scenes = llvm::to_vector(module.getOps<SceneOp>());
  if (scenes.size() != 1)
    return llvm::Error::success();
  SymbolTableCollection tables;
  for (const std::string &text : attributes) {
    auto path = dyn_cast_or_null<SymbolRefAttr>(
        parseAttribute(text, module.getContext()));
    if (path && !isAttributeDecl(lookupInScene(scenes[0], path, &tables)))
      return llvm::make_error<MissingAttributeError>(
          text, scenes[0].getSymName().str());
  }
  return llvm::Error::success();
}

llvm::Expected<OwningOpRef<ModuleOp>> mlir::yasps::generateLoopKernels(
    ModuleOp module, const std::vector<std::string> &attributes,
    StringRef prePipeline, int64_t lanes, int64_t projectionLanes,
    StringRef outStorage) {
  OwningOpRef<ModuleOp> kernels(cast<ModuleOp>(module->clone()));
  if (!prePipeline.empty())
    if (llvm::Error err = runPasses(
            *kernels, "kernel generation failed",
            [&](PassManager &pm) { return parsePassPipeline(prePipeline, pm); },
            // The loop kernels made from it are verified below.
            Verification::Deferred))
      return std::move(err);
  if (llvm::Error err = checkAttributesExist(*kernels, attributes))
    return std::move(err);
  if (llvm::Error err = runPasses(
          *kernels, "kernel generation failed",
          [&](PassManager &pm) {
            YaspsLowerToLoopsOptions lowerOptions;
            lowerOptions.attributes.assign(attributes.begin(),
                                           attributes.end());
            lowerOptions.lanes = lanes;
            lowerOptions.projectionLanes = projectionLanes;
            lowerOptions.storage = "f64";
            lowerOptions.outStorage_ = outStorage.str();
            pm.addPass(createYaspsLowerToLoops(lowerOptions));
            pm.addPass(createYaspsStripScenes());
            // Bottom-up: on the straight-line code of a large projection
            // (the LDL^T test and an scf.if of n^2 results) the default
            // top-down traversal is quadratic in practice, 46 s against
            // 0.7 s at 48x48, for the same result.
            GreedyRewriteConfig bottomUp;
            bottomUp.setUseTopDownTraversal(false);
            pm.addPass(createCanonicalizerPass(bottomUp));
            pm.addPass(createCSEPass());
            pm.addPass(createYaspsCountOps());
            return success();
          },
          Verification::AtEnd))
    return std::move(err);
  return kernels;
}

unsigned mlir::yasps::computeFloatBits(ModuleOp module) {
  unsigned bits = 0;
  module.walk([&](Operation *op) {
    if (isAttributeDecl(op))
      bits = std::max(
          bits, getAttributeType(op).getElementType().getIntOrFloatBitWidth());
  });
  return bits ? bits : 64;
}

std::vector<KernelDescription> mlir::yasps::describeKernels(ModuleOp kernels) {
  std::vector<KernelDescription> result;
  for (auto func : kernels.getOps<func::FuncOp>()) {
    auto of = func->getAttrOfType<SymbolRefAttr>(kKernelOfAttr);
    auto args = func->getAttrOfType<ArrayAttr>(kKernelArgsAttr);
    if (!of || !args)
      continue;
    KernelDescription kernel;
    llvm::raw_string_ostream(kernel.attribute) << of;
    kernel.symbol = func.getSymName().str();
    for (auto arg : args.getAsRange<KernelArgAttr>())
      kernel.arguments.push_back({arg.getKind(), print(arg.getPath())});
    if (auto shape = func->getAttrOfType<DenseI64ArrayAttr>(kKernelShapeAttr)) {
      kernel.rows = shape[0];
      kernel.cols = shape[1];
    }
    if (auto projection =
            func->getAttrOfType<ProjectionKindAttr>(kProjectionAttr))
      kernel.projection = stringifyProjectionKind(projection.getValue()).str();
    if (auto counts = func->getAttrOfType<DictionaryAttr>(kOpCountsAttr))
      for (NamedAttribute entry : counts)
        kernel.opCounts[entry.getName().str()] =
            cast<IntegerAttr>(entry.getValue()).getInt();
    kernel.params = describeParams(func->getAttrOfType<ArrayAttr>(kParamsAttr));
    // The output is the first buffer argument (after begin and end).
    for (auto [arg, role] : llvm::zip(func.getArguments().drop_front(2), args))
      if (cast<KernelArgAttr>(role).getKind() == KernelArgKind::out &&
          cast<MemRefType>(arg.getType()).getElementType().isF32())
        kernel.outType = "f32";
    result.push_back(std::move(kernel));
  }
  return result;
}

std::string mlir::yasps::hashKernels(ModuleOp kernels, StringRef extra) {
  std::string text;
  llvm::raw_string_ostream os(text);
  kernels.print(os, OpPrintingFlags().printGenericOpForm());
  os << "\n" << extra;
  std::array<uint8_t, 32> hash = llvm::SHA256::hash(llvm::ArrayRef(
      reinterpret_cast<const uint8_t *>(text.data()), text.size()));
  return llvm::toHex(hash, /*LowerCase=*/true);
}

void mlir::yasps::storeAtomically(const std::string &path,
                                  llvm::function_ref<void(StringRef)> write) {
  std::string tmp = path + ".tmp." + std::to_string(::getpid());
  write(tmp);
  if (llvm::sys::fs::rename(tmp, path))
    llvm::sys::fs::remove(tmp);
}
