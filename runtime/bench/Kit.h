//===- Kit.h - GPU kernels compiled elsewhere, and running them -*- C++ -*-===//
//
// bench/gpu_kit.py compiles a scene's kernels for GPUs and writes them with
// what running them needs into a folder (a kit), so that a machine with a
// GPU but without MLIR can time them. KIT/kernels.txt, one directive a
// line:
//   image CHIP FORMAT FILE          a binary of the module (cubin or ptx)
//   kernel NAME LABEL THREADS COUNT OUT_VALUES REFERENCE.npy
//   param index|buffer|constant VALUE      (cuLaunchKernel's, in order)
//   buffer FILE.npy | buffer out           (loop-kernel buffer arguments)
//   energy NAME COUNT PARAMS GRAD_LABEL HESSIAN_LABEL DOFS_LABEL
//   layout FILE.npy                        (the DoF blocks' offsets)
//   solution FILE.npy TOLERANCE            (the CPU's Newton direction)
// REFERENCE holds the CPU kernel's first values of the output.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_RUNTIME_BENCH_KIT_H
#define YASPS_RUNTIME_BENCH_KIT_H

#include "yasps/Runtime/Gpu/GpuLaunch.h"
#include "yasps/Runtime/Gpu/HostImage.h"

#include "BenchMain.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace yasps::runtime::bench {

/// A .npy file's raw data (little-endian, C order) and element size.
struct Npy {
  std::string data;
  std::size_t itemSize = 8;
  std::size_t size() const { return data.size() / itemSize; }
  template <typename T> const T *as() const {
    return reinterpret_cast<const T *>(data.data());
  }
};

inline Npy readNpy(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error("cannot read " + path);
  std::string bytes((std::istreambuf_iterator<char>(in)),
                    std::istreambuf_iterator<char>());
  if (bytes.size() < 12 || bytes.compare(0, 6, "\x93NUMPY") != 0)
    throw std::runtime_error(path + " is not a .npy file");
  std::size_t headerLength = 0, start = bytes[6] == 1 ? 10 : 12;
  for (std::size_t k = 8; k < start; ++k)
    headerLength |= std::size_t(std::uint8_t(bytes[k])) << (8 * (k - 8));
  std::string header = bytes.substr(start, headerLength);
  bool eight = header.find("'<f8'") != std::string::npos ||
               header.find("'<i8'") != std::string::npos;
  bool four = header.find("'<i4'") != std::string::npos;
  if (header.find("'fortran_order': False") == std::string::npos ||
      !(eight || four))
    throw std::runtime_error(path + ": only C-order <f8, <i8 and <i4 arrays");
  Npy npy;
  npy.data = bytes.substr(start + headerLength);
  npy.itemSize = four ? 4 : 8;
  return npy;
}

struct KitKernel {
  std::string name, label, reference;
  std::int64_t threads = 128, count = 0, outValues = 0;
  std::vector<GpuParam> params;
  std::vector<std::string> buffers; // file names, "out" for the output
};

struct KitEnergy {
  std::string name, grad, hessian, dofs; // kernel labels
  std::int64_t count = 0, numParams = 0;
};

struct Kit {
  std::string dir;
  std::vector<GpuImage> images;
  std::vector<std::string> imageBytes;
  std::vector<KitKernel> kernels;
  std::vector<KitEnergy> energies;
  std::string layout, solution;
  double tolerance = 0.0;

  const KitKernel &kernel(const std::string &label) const {
    for (const KitKernel &k : kernels)
      if (k.label == label)
        return k;
    throw std::runtime_error("the kit has no kernel " + label);
  }
};

inline Kit readKit(const std::string &dir) {
  std::ifstream in(dir + "/kernels.txt");
  if (!in)
    throw std::runtime_error("cannot read " + dir + "/kernels.txt");
  Kit kit;
  kit.dir = dir;
  std::vector<std::pair<std::string, std::string>> imageNames;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string directive;
    words >> directive;
    if (directive == "image") {
      std::string chip, format, file;
      words >> chip >> format >> file;
      std::ifstream image(dir + "/" + file, std::ios::binary);
      kit.imageBytes.emplace_back(std::istreambuf_iterator<char>(image),
                                  std::istreambuf_iterator<char>());
      imageNames.emplace_back(chip, format);
    } else if (directive == "kernel") {
      KitKernel kernel;
      words >> kernel.name >> kernel.label >> kernel.threads >> kernel.count >>
          kernel.outValues >> kernel.reference;
      kit.kernels.push_back(kernel);
    } else if (directive == "param") {
      std::string kind;
      std::int64_t value;
      words >> kind >> value;
      std::optional<GpuParam::Kind> parsed = parseGpuParamKind(kind);
      if (!parsed)
        throw std::runtime_error("unknown kernel parameter kind " + kind);
      kit.kernels.back().params.push_back({*parsed, value, value});
    } else if (directive == "buffer") {
      std::string file;
      words >> file;
      kit.kernels.back().buffers.push_back(file);
    } else if (directive == "energy") {
      KitEnergy energy;
      words >> energy.name >> energy.count >> energy.numParams >> energy.grad >>
          energy.hessian >> energy.dofs;
      kit.energies.push_back(energy);
    } else if (directive == "layout") {
      words >> kit.layout;
    } else if (directive == "solution") {
      words >> kit.solution >> kit.tolerance;
    }
  }
  // Pointers into imageBytes, which no longer grows.
  for (std::size_t k = 0; k < imageNames.size(); ++k)
    kit.images.push_back(
        {imageNames[k].first, imageNames[k].second, &kit.imageBytes[k]});
  return kit;
}

/// Runs a kit's kernels on a device: inputs uploaded once, each kernel's
/// output in a buffer of its own.
class KitRunner {
public:
  KitRunner(const Kit &kit, const CudaContext &context)
      : kit(kit), ctx(context),
        image(selectGpuImage(kit.images, targetOf(context))),
        module(context, *image.bytes) {}

  const GpuImage &selectedImage() const { return image; }

  /// What the kit's images are chosen for: the device's chip, or the host
  /// image where the driver is the stand-in that runs those (a dry run).
  static std::string targetOf(const CudaContext &context) {
    if (context.driver().runsHostImages())
      return host_image::kChip;
    return context.driver().devices().at(context.ordinal()).chip();
  }

  /// Launches the kernel on all its instances (asynchronously).
  void launch(const KitKernel &kernel) {
    std::vector<GpuBufferArg> args;
    for (const std::string &file : kernel.buffers)
      args.push_back(file == "out" ? GpuBufferArg{output(kernel).pointer(),
                                                  kernel.outValues}
                                   : input(file));
    auto found = functions.find(kernel.name);
    if (found == functions.end())
      found =
          functions.emplace(kernel.name, module.function(kernel.name)).first;
    launchGpuKernel(ctx, found->second, kernel.params, args, 0, kernel.count,
                    kernel.threads);
  }

  DeviceBuffer &output(const KitKernel &kernel) {
    auto found = outputs.find(kernel.label);
    if (found == outputs.end())
      found = outputs
                  .emplace(kernel.label,
                           DeviceBuffer(ctx, kernel.outValues * sizeof(double)))
                  .first;
    return found->second;
  }

  /// The largest difference of the output's first values from the CPU's,
  /// relative to their largest magnitude (after the launch has run).
  double differenceFromReference(const KitKernel &kernel) {
    Npy reference = readNpy(kit.dir + "/" + kernel.reference);
    std::vector<double> got(reference.size());
    output(kernel).download(got.data(), got.size() * sizeof(double));
    return relativeDifference(got.data(), reference.as<double>(), got.size());
  }

private:
  GpuBufferArg input(const std::string &file) {
    auto found = inputs.find(file);
    if (found == inputs.end()) {
      Npy npy = readNpy(kit.dir + "/" + file);
      DeviceBuffer buffer(ctx, npy.data.size());
      buffer.upload(npy.data.data(), npy.data.size());
      found = inputs
                  .emplace(file, std::make_pair(std::move(buffer),
                                                std::int64_t(npy.size())))
                  .first;
    }
    return {found->second.first.pointer(), found->second.second};
  }

  const Kit &kit;
  const CudaContext &ctx;
  const GpuImage &image;
  CudaModule module;
  std::map<std::string, cu::Function> functions;
  // Per input file: its device copy and element count.
  std::map<std::string, std::pair<DeviceBuffer, std::int64_t>> inputs;
  std::map<std::string, DeviceBuffer> outputs;
};

} // namespace yasps::runtime::bench

#endif // YASPS_RUNTIME_BENCH_KIT_H
