//===- GpuLaunch.cpp - loading and launching yasps GPU kernels ------------===//

#include "yasps/Runtime/Gpu/GpuLaunch.h"
#include "yasps/Runtime/Gpu/HostImage.h"

#include <cstdlib>

using namespace yasps::runtime;

namespace {
/// "sm_90" -> 90.
int chipNumber(const std::string &chip) {
  std::size_t digits = chip.find_first_of("0123456789");
  return digits == std::string::npos ? 0 : std::atoi(chip.c_str() + digits);
}
} // namespace

const GpuImage &
yasps::runtime::selectGpuImage(const std::vector<GpuImage> &images,
                               const std::string &chip) {
  for (const GpuImage &image : images)
    if (image.format == "cubin" && image.chip == chip)
      return image;
  // The stand-in driver's "chip" runs host images only (HostImage.h).
  for (const GpuImage &image : images)
    if (chip == host_image::kChip && image.format == host_image::kFormat)
      return image;
  // A cubin runs on later chips of its major version (sm_80 on sm_86).
  const GpuImage *cubin = nullptr;
  int device = chipNumber(chip);
  for (const GpuImage &image : images)
    if (image.format == "cubin" && chipNumber(image.chip) / 10 == device / 10 &&
        chipNumber(image.chip) <= device &&
        (!cubin || chipNumber(image.chip) > chipNumber(cubin->chip)))
      cubin = &image;
  if (cubin)
    return *cubin;
  // PTX of the newest chip that the device is at least.
  const GpuImage *best = nullptr;
  for (const GpuImage &image : images)
    if (image.format == "ptx" && chipNumber(image.chip) <= chipNumber(chip) &&
        (!best || chipNumber(image.chip) > chipNumber(best->chip)))
      best = &image;
  if (best)
    return *best;
  std::string have;
  for (const GpuImage &image : images)
    have += (have.empty() ? "" : ", ") + image.chip + " " + image.format;
  throw CudaError("no GPU binary runs on this device (" + chip +
                      "): the kernels were compiled to " +
                      (have.empty() ? std::string("nothing") : have),
                  0);
}

CudaModule::CudaModule(const CudaContext &context, const std::string &image)
    : ctx(context) {
  context.makeCurrent();
  // PTX must be NUL-terminated; std::string's buffer is.
  context.driver().check(
      context.driver().cuModuleLoadData(&module, image.c_str()),
      "cuModuleLoadData");
}

CudaModule::~CudaModule() {
  if (module)
    ctx.driver().cuModuleUnload(module);
}

cu::Function CudaModule::function(const std::string &name) const {
  cu::Function fn = nullptr;
  cu::Result result =
      ctx.driver().cuModuleGetFunction(&fn, module, name.c_str());
  if (result != cu::kSuccess)
    throw CudaError("the GPU module has no kernel " + name + ": " +
                        ctx.driver().describe(result),
                    result);
  return fn;
}

GpuLaunchParams::GpuLaunchParams(const std::vector<GpuParam> &params,
                                 const std::vector<GpuBufferArg> &buffers,
                                 std::int64_t begin, std::int64_t end) {
  for (const GpuParam &param : params) {
    switch (param.kind) {
    case GpuParam::Kind::Index:
      if (param.argument != 0 && param.argument != 1)
        throw std::invalid_argument("GPU kernel parameter: index argument " +
                                    std::to_string(param.argument));
      storage.push_back(std::uint64_t(param.argument == 0 ? begin : end));
      break;
    case GpuParam::Kind::Buffer: {
      std::int64_t slot = param.argument - 2;
      if (slot < 0 || slot >= std::int64_t(buffers.size()))
        throw std::invalid_argument("GPU kernel parameter: buffer argument " +
                                    std::to_string(param.argument) + " of " +
                                    std::to_string(buffers.size() + 2) +
                                    " arguments");
      const GpuBufferArg &buffer = buffers[slot];
      // MLIR's memref<?xT> descriptor, flattened.
      storage.push_back(buffer.pointer);
      storage.push_back(buffer.pointer);
      storage.push_back(0);
      storage.push_back(std::uint64_t(buffer.size));
      storage.push_back(1);
      break;
    }
    case GpuParam::Kind::Constant:
      storage.push_back(std::uint64_t(param.value));
      break;
    }
  }
  // Addresses are taken once storage no longer moves.
  for (std::uint64_t &value : storage)
    addresses.push_back(&value);
}

void yasps::runtime::launchGpuKernel(const CudaContext &context,
                                     cu::Function kernel,
                                     const std::vector<GpuParam> &params,
                                     const std::vector<GpuBufferArg> &buffers,
                                     std::int64_t begin, std::int64_t end,
                                     std::int64_t threadsPerBlock) {
  if (threadsPerBlock < 1 || begin > end)
    throw std::invalid_argument(
        "GPU launch of [" + std::to_string(begin) + ", " + std::to_string(end) +
        ") with " + std::to_string(threadsPerBlock) + " threads per block");
  if (begin == end)
    return;
  GpuLaunchParams values(params, buffers, begin, end);
  std::int64_t blocks = (end - begin + threadsPerBlock - 1) / threadsPerBlock;
  context.makeCurrent();
  context.driver().check(
      context.driver().cuLaunchKernel(kernel, unsigned(blocks), 1, 1,
                                      unsigned(threadsPerBlock), 1, 1, 0,
                                      nullptr, values.pointers(), nullptr),
      "cuLaunchKernel");
}
