//===- KernelBench.cpp - timing compiled yasps kernels on a GPU -----------===//
//
// yasps-kernel-bench KIT [--repeat N]
//
// Runs the GPU kernels that bench/gpu_kit.py compiled (cubins and PTX of a
// scene's derivative kernels, with the compiler's recorded launch ABI and
// the scene's input buffers as .npy files), checks each output's first
// instances against the CPU kernels' values the kit holds, and prints the
// time per launch over all instances. Needs no MLIR or Python, so that
// kernels compiled here can be timed on a GPU machine without this
// toolchain.
//
// KIT/kernels.txt, one directive a line:
//   image CHIP FORMAT FILE      a binary of the module (cubin or ptx)
//   count N                     instances of every kernel
//   kernel NAME LABEL THREADS OUT_VALUES REFERENCE.npy
//   param index|buffer|constant VALUE     (cuLaunchKernel's, in order)
//   buffer FILE.npy | buffer out          (loop-kernel buffer arguments)
//   end
//
//===----------------------------------------------------------------------===//

#include "yasps/Runtime/GpuLaunch.h"

#include "BenchMain.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

using namespace yasps::runtime;

namespace {

/// A .npy file's raw data (little-endian, C order) and element size.
struct Npy {
  std::string data;
  std::size_t itemSize = 8;
  std::size_t size() const { return data.size() / itemSize; }
};

Npy readNpy(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error("cannot read " + path);
  std::string bytes((std::istreambuf_iterator<char>(in)),
                    std::istreambuf_iterator<char>());
  if (bytes.compare(0, 6, "\x93NUMPY") != 0 || bytes.size() < 10)
    throw std::runtime_error(path + " is not a .npy file");
  std::size_t headerLength, start;
  if (bytes[6] == 1) {
    headerLength = std::uint8_t(bytes[8]) | std::uint8_t(bytes[9]) << 8;
    start = 10;
  } else {
    headerLength = 0;
    for (int k = 0; k < 4; ++k)
      headerLength |= std::size_t(std::uint8_t(bytes[8 + k])) << (8 * k);
    start = 12;
  }
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

struct Kernel {
  std::string name, label, reference;
  std::int64_t threads = 128, outValues = 0;
  std::vector<GpuParam> params;
  std::vector<std::string> buffers; // file names, "out" for the output
};

struct Kit {
  std::vector<std::string> imageChips, imageFormats, imageFiles;
  std::int64_t count = 0;
  std::vector<Kernel> kernels;
};

Kit readKit(const std::string &dir) {
  std::ifstream in(dir + "/kernels.txt");
  if (!in)
    throw std::runtime_error("cannot read " + dir + "/kernels.txt");
  Kit kit;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string directive;
    words >> directive;
    if (directive == "image") {
      std::string chip, format, file;
      words >> chip >> format >> file;
      kit.imageChips.push_back(chip);
      kit.imageFormats.push_back(format);
      kit.imageFiles.push_back(file);
    } else if (directive == "count") {
      words >> kit.count;
    } else if (directive == "kernel") {
      Kernel kernel;
      words >> kernel.name >> kernel.label >> kernel.threads >>
          kernel.outValues >> kernel.reference;
      kit.kernels.push_back(kernel);
    } else if (directive == "param") {
      std::string kind;
      std::int64_t value;
      words >> kind >> value;
      GpuParam param{kind == "index"    ? GpuParam::Kind::Index
                     : kind == "buffer" ? GpuParam::Kind::Buffer
                                        : GpuParam::Kind::Constant,
                     value, value};
      kit.kernels.back().params.push_back(param);
    } else if (directive == "buffer") {
      std::string file;
      words >> file;
      kit.kernels.back().buffers.push_back(file);
    }
  }
  return kit;
}

int run(int argc, char **argv) {
  if (argc < 2) {
    std::cerr << "usage: yasps-kernel-bench KIT [--repeat N]\n";
    return 2;
  }
  std::string dir = argv[1];
  int repeat = 50;
  for (int a = 2; a + 1 < argc; ++a)
    if (!std::strcmp(argv[a], "--repeat"))
      repeat = std::atoi(argv[++a]);
  Kit kit = readKit(dir);
  CudaDriver &driver = CudaDriver::get();
  driver.requireUsable();
  CudaContext context(driver, 0);
  const std::string chip = driver.devices()[0].chip();
  std::vector<std::string> bytes(kit.imageFiles.size());
  std::vector<GpuImage> images;
  for (std::size_t k = 0; k < kit.imageFiles.size(); ++k) {
    std::ifstream in(dir + "/" + kit.imageFiles[k], std::ios::binary);
    bytes[k].assign(std::istreambuf_iterator<char>(in),
                    std::istreambuf_iterator<char>());
  }
  for (std::size_t k = 0; k < bytes.size(); ++k)
    images.push_back({kit.imageChips[k], kit.imageFormats[k], &bytes[k]});
  const GpuImage &image = selectGpuImage(images, chip);
  CudaModule module(context, *image.bytes);
  std::printf("%lld instances on %s (%s, %s %s)\n", (long long)kit.count,
              driver.devices()[0].name.c_str(), chip.c_str(),
              image.chip.c_str(), image.format.c_str());
  std::fflush(stdout);

  // Per input file: its device copy and element count.
  std::map<std::string, std::pair<DeviceBuffer, std::int64_t>> inputs;
  for (const Kernel &kernel : kit.kernels) {
    std::vector<GpuBufferArg> args;
    DeviceBuffer out(context, kernel.outValues * sizeof(double));
    for (const std::string &file : kernel.buffers) {
      if (file == "out") {
        args.push_back({out.pointer(), kernel.outValues});
        continue;
      }
      auto found = inputs.find(file);
      if (found == inputs.end()) {
        Npy npy = readNpy(dir + "/" + file);
        DeviceBuffer buffer(context, npy.data.size());
        buffer.upload(npy.data.data(), npy.data.size());
        found = inputs
                    .emplace(file, std::make_pair(std::move(buffer),
                                                  std::int64_t(npy.size())))
                    .first;
      }
      args.push_back({found->second.first.pointer(), found->second.second});
    }
    cu::Function function = module.function(kernel.name);
    auto launch = [&] {
      launchGpuKernel(context, function, kernel.params, args, 0, kit.count,
                      kernel.threads);
    };
    launch();
    context.synchronize();
    Npy reference = readNpy(dir + "/" + kernel.reference);
    std::vector<double> got(reference.size());
    out.download(got.data(), got.size() * sizeof(double));
    const double *want =
        reinterpret_cast<const double *>(reference.data.data());
    double diff = 0.0, scale = 0.0;
    for (std::size_t i = 0; i < got.size(); ++i) {
      diff = std::max(diff, std::fabs(got[i] - want[i]));
      scale = std::max(scale, std::fabs(want[i]));
    }
    auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < repeat; ++k)
      launch();
    context.synchronize();
    double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count() /
        repeat;
    std::printf("  %-10s %10.4f ms  (first %zu values within %.1e of the "
                "CPU's)\n",
                kernel.label.c_str(), seconds * 1e3, got.size(), diff / scale);
    if (!(diff <= 1e-10 * scale)) {
      std::printf("  %s differs from the CPU\n", kernel.label.c_str());
      return 1;
    }
  }
  return 0;
}

} // namespace

int main(int argc, char **argv) {
  return yasps::runtime::bench::runReportingErrors("yasps-kernel-bench", run,
                                                   argc, argv);
}
