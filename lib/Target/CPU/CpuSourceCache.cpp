//===- CpuSourceCache.cpp - compiled kernels found by their source --------===//

#include "yasps/Target/CPU/CpuSourceCache.h"

#include "llvm/ADT/StringExtras.h"
#include "llvm/Support/FileSystem.h"
#include "llvm/Support/JSON.h"
#include "llvm/Support/MemoryBuffer.h"
#include "llvm/Support/Path.h"
#include "llvm/Support/SHA256.h"
#include "llvm/Support/raw_ostream.h"
#include "llvm/TargetParser/Host.h"

#include <dlfcn.h>

using namespace mlir;
using namespace mlir::yasps;
namespace json = llvm::json;

namespace {

/// This build of the compiler: the file holding this code, its size and
/// modification time. A rebuilt compiler may lower the same IR otherwise,
/// so its requests never find a previous build's records.
const std::string &buildIdentity() {
  static const std::string identity = [] {
    Dl_info info;
    std::string text = "unknown";
    if (dladdr(reinterpret_cast<void *>(&cpuSourceKey), &info) &&
        info.dli_fname) {
      llvm::sys::fs::file_status status;
      text = info.dli_fname;
      if (!llvm::sys::fs::status(info.dli_fname, status))
        text +=
            ":" + std::to_string(status.getSize()) + ":" +
            std::to_string(
                status.getLastModificationTime().time_since_epoch().count());
    }
    return text;
  }();
  return identity;
}

std::string recordPath(const std::string &key,
                       const CpuCompileOptions &options) {
  llvm::SmallString<256> path(options.cacheDir);
  llvm::sys::path::append(path, key + ".source.json");
  return path.str().str();
}

json::Value kernelRecord(const CpuKernel &kernel) {
  json::Array arguments, params;
  for (const KernelArgument &arg : kernel.arguments)
    arguments.push_back(
        json::Array{mlir::yasps::stringifyKernelArgKind(arg.kind), arg.path});
  for (const auto &fields : kernel.params)
    params.push_back(json::Array(fields));
  json::Object counts;
  for (const auto &[name, count] : kernel.opCounts)
    counts[name] = count;
  return json::Object{{"attribute", kernel.attribute},
                      {"symbol", kernel.symbol},
                      {"object", kernel.objectKey},
                      {"arguments", std::move(arguments)},
                      {"rows", kernel.rows},
                      {"cols", kernel.cols},
                      {"projection", kernel.projection},
                      {"out_type", kernel.outType},
                      {"params", std::move(params)},
                      {"op_counts", std::move(counts)}};
}

std::optional<std::string> text(const json::Value *value) {
  if (!value)
    return std::nullopt;
  if (auto s = value->getAsString())
    return s->str();
  return std::nullopt;
}

/// The kernel of a record entry, or nothing if it is malformed.
std::optional<CpuKernel> kernelOf(const json::Value &value) {
  const json::Object *object = value.getAsObject();
  if (!object)
    return std::nullopt;
  CpuKernel kernel;
  auto attribute = text(object->get("attribute"));
  auto symbol = text(object->get("symbol"));
  auto objectKey = text(object->get("object"));
  auto projection = text(object->get("projection"));
  // The output buffer's type: without it an f32 scene's kernels, found by
  // a later process, were read as writing f64.
  auto outType = text(object->get("out_type"));
  auto rows = object->getInteger("rows");
  auto cols = object->getInteger("cols");
  const json::Array *arguments = object->getArray("arguments");
  const json::Array *params = object->getArray("params");
  const json::Object *counts = object->getObject("op_counts");
  if (!attribute || !symbol || !objectKey || !projection || !outType || !rows ||
      !cols || !arguments || !params || !counts ||
      (*outType != "f64" && *outType != "f32"))
    return std::nullopt;
  kernel.objectKey = *objectKey;
  kernel.attribute = *attribute;
  kernel.symbol = *symbol;
  kernel.projection = *projection;
  kernel.outType = *outType;
  kernel.rows = *rows;
  kernel.cols = *cols;
  for (const json::Value &arg : *arguments) {
    const json::Array *pair = arg.getAsArray();
    if (!pair || pair->size() != 2)
      return std::nullopt;
    auto spelling = text(&(*pair)[0]);
    auto path = text(&(*pair)[1]);
    std::optional<mlir::yasps::KernelArgKind> kind =
        spelling ? mlir::yasps::symbolizeKernelArgKind(*spelling)
                 : std::nullopt;
    if (!kind || !path)
      return std::nullopt;
    kernel.arguments.push_back({*kind, *path});
  }
  for (const json::Value &param : *params) {
    const json::Array *fields = param.getAsArray();
    if (!fields)
      return std::nullopt;
    std::vector<std::string> out;
    for (const json::Value &field : *fields) {
      auto s = text(&field);
      if (!s)
        return std::nullopt;
      out.push_back(*s);
    }
    kernel.params.push_back(std::move(out));
  }
  for (const auto &[name, count] : *counts) {
    auto value = count.getAsInteger();
    if (!value)
      return std::nullopt;
    kernel.opCounts[name.str()] = *value;
  }
  return kernel;
}

} // namespace

std::string mlir::yasps::cpuSourceKey(
    llvm::StringRef ir, const std::vector<std::string> &attributes,
    llvm::StringRef prePipeline, const CpuCompileOptions &options) {
  llvm::SHA256 hash;
  auto add = [&](llvm::StringRef part) {
    hash.update(part);
    hash.update(llvm::StringRef("\0", 1));
  };
  add(ir);
  for (const std::string &attribute : attributes)
    add(attribute);
  add(prePipeline);
  add(std::to_string(options.optLevel));
  add(std::to_string(options.lanes));
  add(options.targetCpu);
  add(llvm::sys::getHostCPUName());
  add(buildIdentity());
  std::array<uint8_t, 32> digest = hash.final();
  return "src-" + llvm::toHex(digest, /*LowerCase=*/true);
}

std::shared_ptr<CpuKernelLibrary>
mlir::yasps::lookupCpuSource(const std::string &sourceKey,
                             const CpuCompileOptions &options,
                             CpuCompileStats &stats) {
  if (options.cacheDir.empty())
    return nullptr;
  auto buffer = llvm::MemoryBuffer::getFile(recordPath(sourceKey, options));
  if (!buffer)
    return nullptr;
  llvm::Expected<json::Value> parsed = json::parse((*buffer)->getBuffer());
  if (!parsed) {
    llvm::consumeError(parsed.takeError());
    return nullptr;
  }
  const json::Object *record = parsed->getAsObject();
  const json::Array *kernels = record ? record->getArray("kernels") : nullptr;
  if (!kernels)
    return nullptr;
  std::vector<CpuKernel> described;
  for (const json::Value &entry : *kernels) {
    std::optional<CpuKernel> kernel = kernelOf(entry);
    if (!kernel)
      return nullptr; // a damaged record: compile again
    described.push_back(std::move(*kernel));
  }
  auto library = loadCachedCpuKernels(std::move(described), options, stats);
  if (library)
    stats.fromSource = true;
  return library;
}

void mlir::yasps::recordCpuSource(const std::string &sourceKey,
                                  const CpuKernelLibrary &library,
                                  const CpuCompileOptions &options) {
  if (options.cacheDir.empty())
    return;
  json::Array kernels;
  for (const CpuKernel &kernel : library.kernels())
    kernels.push_back(kernelRecord(kernel));
  json::Value record = json::Object{{"kernels", std::move(kernels)}};
  llvm::sys::fs::create_directories(options.cacheDir);
  storeAtomically(recordPath(sourceKey, options), [&](llvm::StringRef tmp) {
    std::error_code error;
    llvm::raw_fd_ostream os(tmp, error);
    if (!error)
      os << record;
  });
}
