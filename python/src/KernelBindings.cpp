//===- KernelBindings.cpp - launching compiled CPU kernels from Python
//-----===//

#include "KernelBindings.h"

#include "ThreadPools.h"

#include "yasps/Runtime/Support/CpuKernel.h"

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace nb = nanobind;

namespace {

using Buffer = nb::ndarray<nb::c_contig, nb::device::cpu>;

/// The dtype and name of a buffer code of CpuLibrary.entry: int32 (i),
/// int64 (q), float32 (f) or float64 (d).
std::pair<nb::dlpack::dtype, const char *> codeType(char code) {
  switch (code) {
  case 'i':
    return {nb::dtype<std::int32_t>(), "int32"};
  case 'q':
    return {nb::dtype<std::int64_t>(), "int64"};
  case 'f':
    return {nb::dtype<float>(), "float32"};
  case 'd':
    return {nb::dtype<double>(), "float64"};
  default:
    throw std::invalid_argument(std::string("unknown kernel buffer code '") +
                                code + "'");
  }
}

/// The kernel arguments of `buffers`, checked against `codes`.
std::vector<::yasps::runtime::KernelBuffer>
kernelArguments(const std::string &codes, const std::vector<Buffer> &buffers) {
  if (buffers.size() != codes.size())
    throw std::invalid_argument(
        "the kernel takes " + std::to_string(codes.size()) + " buffers, got " +
        std::to_string(buffers.size()));
  std::vector<::yasps::runtime::KernelBuffer> args;
  args.reserve(buffers.size());
  for (size_t i = 0; i < buffers.size(); ++i) {
    auto [dtype, name] = codeType(codes[i]);
    if (buffers[i].dtype() != dtype || buffers[i].ndim() != 1)
      throw std::invalid_argument("kernel buffer " + std::to_string(i) +
                                  " must be 1-D " + name);
    args.push_back(
        {buffers[i].data(), static_cast<std::int64_t>(buffers[i].shape(0))});
  }
  return args;
}

/// Runs the packed kernel at `entry` on instances [0, numInstances);
/// `buffers` follow its arguments, each 1-D of the type `codes` gives.
void launch(std::uintptr_t entry, const std::string &codes,
            std::int64_t numInstances, const std::vector<Buffer> &buffers,
            unsigned threads) {
  std::vector<::yasps::runtime::KernelBuffer> args =
      kernelArguments(codes, buffers);
  nb::gil_scoped_release release;
  ::yasps::runtime::launchCpuKernel(
      reinterpret_cast<::yasps::runtime::PackedKernelFn>(entry), args,
      numInstances, ::yasps::python::poolFor(threads), /*minChunk=*/256);
}

/// Runs several scalar f64 kernels (a scene's energies) and returns the sum
/// of every output, kernel after kernel: kernel k at entries[k] with buffer
/// codes codes[k] on counts[k] instances, its input buffers in `inputs[k]`
/// (in argument order, without the output, which goes at argument
/// outputs[k] and is allocated here). The sums are compensated (Neumaier),
/// so that they do not depend on the instance count's rounding: the line
/// search compares totals whose difference can be below a plain sum's
/// round-off.
double sumKernels(const std::vector<std::uintptr_t> &entries,
                  const std::vector<std::string> &codes,
                  const std::vector<std::int64_t> &counts,
                  const std::vector<std::vector<Buffer>> &inputs,
                  const std::vector<std::int64_t> &outputs, unsigned threads) {
  const size_t n = entries.size();
  if (codes.size() != n || counts.size() != n || inputs.size() != n ||
      outputs.size() != n)
    throw std::invalid_argument("sum_cpu_kernels: " + std::to_string(n) +
                                " entries, but the other lists differ");
  std::vector<std::vector<::yasps::runtime::KernelBuffer>> args(n);
  std::vector<std::vector<double>> values(n);
  for (size_t k = 0; k < n; ++k) {
    const std::int64_t out = outputs[k];
    if (out < 0 || out >= static_cast<std::int64_t>(codes[k].size()) ||
        codes[k][out] != 'd' || counts[k] < 0)
      throw std::invalid_argument(
          "sum_cpu_kernels: kernel " + std::to_string(k) +
          " has no f64 output at argument " + std::to_string(out));
    std::string inputCodes = codes[k];
    inputCodes.erase(static_cast<size_t>(out), 1);
    args[k] = kernelArguments(inputCodes, inputs[k]);
    values[k].resize(static_cast<size_t>(counts[k]));
    args[k].insert(args[k].begin() + out,
                   {values[k].data(), static_cast<std::int64_t>(counts[k])});
  }
  nb::gil_scoped_release release;
  ::yasps::runtime::ThreadPool &pool = ::yasps::python::poolFor(threads);
  double sum = 0.0, compensation = 0.0;
  for (size_t k = 0; k < n; ++k) {
    ::yasps::runtime::launchCpuKernel(
        reinterpret_cast<::yasps::runtime::PackedKernelFn>(entries[k]), args[k],
        counts[k], pool, /*minChunk=*/256);
    for (double value : values[k]) {
      const double t = sum + value;
      compensation += std::abs(sum) >= std::abs(value) ? (sum - t) + value
                                                       : (value - t) + sum;
      sum = t;
    }
  }
  return sum + compensation;
}

} // namespace

void yasps::python::bindKernelLaunch(nb::module_ &m) {
  m.def("sum_cpu_kernels", &sumKernels, nb::arg("entries"), nb::arg("codes"),
        nb::arg("counts"), nb::arg("inputs"), nb::arg("outputs"),
        nb::arg("threads") = 0,
        "Runs scalar f64 CPU kernels (a scene's energies) on the runtime's "
        "threads and returns the compensated sum of all their outputs.");
  m.def("launch_cpu_kernel", &launch, nb::arg("entry"), nb::arg("codes"),
        nb::arg("num_instances"), nb::arg("buffers"), nb::arg("threads") = 0,
        "Runs a compiled CPU kernel (CpuLibrary.entry: its address and "
        "buffer codes) on num_instances instances on the runtime's threads.");
}
