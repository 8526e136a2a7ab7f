//===- GpuRuntimeBindings.cpp - the CUDA runtime for Python ---------------===//
//
// Exposes the runtime's GPU backend (runtime/include/yasps/Runtime/Cuda*.h,
// GpuLaunch.h) to python/yasps/gpu.py: the driver's status, a device
// context, device buffers filled from and read back into NumPy arrays,
// modules loaded from compiled binaries, and kernel launches by the
// compiler's recorded parameter ABI. Driver errors become `CudaError`
// (a RuntimeError) with the driver's message.
//
//===----------------------------------------------------------------------===//

#include "GpuRuntimeBindings.h"

#include "yasps/Runtime/GpuLaunch.h"

#include <nanobind/ndarray.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <memory>

namespace nb = nanobind;
using namespace yasps::runtime;

namespace {

using HostArray = nb::ndarray<nb::c_contig, nb::device::cpu>;

/// A device's context, kept alive by every buffer and module made in it.
struct PyDevice {
  std::shared_ptr<CudaContext> context;
};

struct PyBuffer {
  std::shared_ptr<CudaContext> context;
  std::shared_ptr<DeviceBuffer> buffer;
  std::int64_t elements = 0;
};

struct PyModule {
  std::shared_ptr<CudaContext> context;
  std::shared_ptr<CudaModule> module;
};

std::size_t byteSize(const HostArray &array) {
  return array.size() * (array.dtype().bits / 8);
}

PyDevice openDevice(int ordinal) {
  CudaDriver &driver = CudaDriver::get();
  driver.requireUsable();
  if (ordinal < 0 || ordinal >= int(driver.devices().size()))
    throw CudaError("no CUDA device " + std::to_string(ordinal) +
                        " (the driver lists " +
                        std::to_string(driver.devices().size()) + ")",
                    0);
  return {std::make_shared<CudaContext>(driver, ordinal)};
}

PyBuffer allocate(const PyDevice &device, std::size_t bytes,
                  std::int64_t elements) {
  return {device.context,
          std::make_shared<DeviceBuffer>(*device.context, bytes), elements};
}

PyBuffer upload(const PyDevice &device, HostArray array) {
  PyBuffer out = allocate(device, byteSize(array), std::int64_t(array.size()));
  out.buffer->upload(array.data(), byteSize(array));
  return out;
}

void download(const PyBuffer &buffer, HostArray array) {
  if (byteSize(array) > buffer.buffer->size())
    throw std::out_of_range("reading " + std::to_string(byteSize(array)) +
                            " bytes from a device buffer of " +
                            std::to_string(buffer.buffer->size()));
  buffer.buffer->download(array.data(), byteSize(array));
}

GpuParam toParam(const std::pair<std::string, std::int64_t> &param) {
  if (param.first == "index")
    return {GpuParam::Kind::Index, param.second, 0};
  if (param.first == "buffer")
    return {GpuParam::Kind::Buffer, param.second, 0};
  if (param.first == "constant")
    return {GpuParam::Kind::Constant, -1, param.second};
  throw std::invalid_argument("unknown GPU kernel parameter kind '" +
                              param.first + "'");
}

void launch(const PyModule &module, const std::string &kernel,
            const std::vector<std::pair<std::string, std::int64_t>> &params,
            const std::vector<PyBuffer> &buffers, std::int64_t begin,
            std::int64_t end, std::int64_t threadsPerBlock) {
  std::vector<GpuParam> recorded;
  for (const auto &param : params)
    recorded.push_back(toParam(param));
  std::vector<GpuBufferArg> args;
  for (const PyBuffer &buffer : buffers)
    args.push_back({buffer.buffer->pointer(), buffer.elements});
  launchGpuKernel(*module.context, module.module->function(kernel), recorded,
                  args, begin, end, threadsPerBlock);
}

} // namespace

void yasps::python::bindGpuRuntime(nb::module_ &m) {
  nb::exception<CudaError>(m, "CudaError", PyExc_RuntimeError);

  m.def(
      "cuda_status",
      [] {
        CudaDriver &driver = CudaDriver::get();
        std::vector<std::tuple<std::string, std::string, std::size_t>> devices;
        for (const CudaDeviceInfo &info : driver.devices())
          devices.emplace_back(info.name, info.chip(), info.totalMemory);
        return std::make_tuple(driver.usable(), driver.unusableReason(),
                               devices);
      },
      "(usable, reason it is not, [(name, chip, total bytes)]) of the CUDA "
      "driver, loaded on first call");

  nb::class_<PyDevice>(m, "GpuDevice", "A CUDA device's primary context.")
      .def(nb::new_(&openDevice), nb::arg("ordinal") = 0)
      .def(
          "synchronize",
          [](const PyDevice &self) { self.context->synchronize(); },
          "Waits for every launch on the device to finish");

  nb::class_<PyBuffer>(m, "GpuBuffer", "Device memory.")
      .def_prop_ro("bytes",
                   [](const PyBuffer &self) { return self.buffer->size(); })
      .def("download", &download, nb::arg("out"),
           "Copies the buffer's first out.nbytes bytes into the C-contiguous "
           "array `out` (waits for earlier launches)");
  m.def("gpu_upload", &upload, nb::arg("device"), nb::arg("array"),
        "A device buffer holding a copy of the C-contiguous array");
  m.def(
      "gpu_allocate",
      [](const PyDevice &device, std::int64_t elements, std::size_t itemSize) {
        return allocate(device, std::size_t(elements) * itemSize, elements);
      },
      nb::arg("device"), nb::arg("elements"), nb::arg("item_size") = 8,
      "An uninitialised device buffer of `elements` items");

  nb::class_<PyModule>(m, "GpuModule", "Kernels loaded from a binary.");
  m.def(
      "gpu_load_module",
      [](const PyDevice &device, nb::bytes image) {
        std::string bytes(image.c_str(), image.size());
        return PyModule{device.context,
                        std::make_shared<CudaModule>(*device.context, bytes)};
      },
      nb::arg("device"), nb::arg("image"),
      "Loads a cubin or PTX (compiled by the driver) into the device");
  m.def(
      "gpu_select_image",
      [](const std::vector<std::pair<std::string, std::string>> &available,
         const std::string &chip) {
        std::vector<GpuImage> images;
        for (const auto &[imageChip, format] : available)
          images.push_back({imageChip, format, nullptr});
        const GpuImage &image = selectGpuImage(images, chip);
        return std::make_pair(image.chip, image.format);
      },
      nb::arg("available"), nb::arg("chip"),
      "The (chip, format) of the binary a device of `chip` runs");
  m.def("gpu_launch", &launch, nb::arg("module"), nb::arg("kernel"),
        nb::arg("params"), nb::arg("buffers"), nb::arg("begin"), nb::arg("end"),
        nb::arg("threads_per_block"),
        "Launches `kernel` on instances [begin, end): params are the "
        "recorded (kind, value) pairs, buffers the loop kernel's buffer "
        "arguments in order");
}
