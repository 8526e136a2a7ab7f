//===- KernelBindings.cpp - launching compiled CPU kernels from Python
//-----===//

#include "KernelBindings.h"

#include "ThreadPools.h"

#include "yasps/Runtime/CpuKernel.h"

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

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

/// Runs the packed kernel at `entry` on instances [0, numInstances);
/// `buffers` follow its arguments, each 1-D of the type `codes` gives.
void launch(std::uintptr_t entry, const std::string &codes,
            std::int64_t numInstances, const std::vector<Buffer> &buffers,
            unsigned threads) {
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
  nb::gil_scoped_release release;
  ::yasps::runtime::launchCpuKernel(
      reinterpret_cast<::yasps::runtime::PackedKernelFn>(entry), args,
      numInstances, ::yasps::python::poolFor(threads), /*minChunk=*/256);
}

} // namespace

void yasps::python::bindKernelLaunch(nb::module_ &m) {
  m.def("launch_cpu_kernel", &launch, nb::arg("entry"), nb::arg("codes"),
        nb::arg("num_instances"), nb::arg("buffers"), nb::arg("threads") = 0,
        "Runs a compiled CPU kernel (CpuLibrary.entry: its address and "
        "buffer codes) on num_instances instances on the runtime's threads.");
}
