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

#include "yasps/Runtime/Gpu/GpuLaunch.h"
#include "yasps/Runtime/Gpu/GpuSystem.h"

#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/shared_ptr.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <chrono>
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

/// Copies `array` to the start of `buffer`, which then holds its elements.
void uploadInto(PyBuffer &buffer, HostArray array) {
  if (byteSize(array) > buffer.buffer->size())
    throw std::out_of_range("writing " + std::to_string(byteSize(array)) +
                            " bytes into a device buffer of " +
                            std::to_string(buffer.buffer->size()));
  buffer.buffer->upload(array.data(), byteSize(array));
  buffer.elements = std::int64_t(array.size());
}

void download(const PyBuffer &buffer, HostArray array) {
  if (byteSize(array) > buffer.buffer->size())
    throw std::out_of_range("reading " + std::to_string(byteSize(array)) +
                            " bytes from a device buffer of " +
                            std::to_string(buffer.buffer->size()));
  buffer.buffer->download(array.data(), byteSize(array));
}

/// A DLPack-capable view of `buffer`'s doubles (no copy): `shape` and
/// `strides` in elements; the view keeps the buffer alive.
nb::ndarray<nb::array_api, double, nb::device::cuda>
dlpackView(const PyBuffer &buffer, const std::vector<std::size_t> &shape,
           const std::vector<std::int64_t> &strides) {
  if (shape.size() != strides.size())
    throw std::invalid_argument("dlpack_view: shape and strides differ in "
                                "length");
  std::int64_t last = 0;
  bool empty = false;
  for (std::size_t k = 0; k < shape.size(); ++k) {
    if (strides[k] < 0)
      throw std::invalid_argument("dlpack_view: negative stride");
    empty |= shape[k] == 0;
    if (shape[k] > 0)
      last += std::int64_t(shape[k] - 1) * strides[k];
  }
  if (!empty && std::size_t(last + 1) * sizeof(double) > buffer.buffer->size())
    throw std::out_of_range("dlpack_view: the view reaches element " +
                            std::to_string(last) + " of a buffer of " +
                            std::to_string(buffer.buffer->size() / 8) +
                            " doubles");
  auto *keep = new PyBuffer(buffer);
  nb::capsule owner(
      keep, [](void *p) noexcept { delete static_cast<PyBuffer *>(p); });
  return nb::ndarray<nb::array_api, double, nb::device::cuda>(
      reinterpret_cast<void *>(buffer.buffer->pointer()), shape.size(),
      shape.data(), owner, strides.data(), nb::dtype<double>(),
      nb::device::cuda::value, buffer.context->ordinal());
}

GpuParam toParam(const std::pair<std::string, std::int64_t> &param) {
  std::optional<GpuParam::Kind> kind = parseGpuParamKind(param.first);
  if (!kind)
    throw std::invalid_argument("unknown GPU kernel parameter kind '" +
                                param.first + "'");
  if (*kind == GpuParam::Kind::Constant)
    return {*kind, -1, param.second};
  return {*kind, param.second, 0};
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
                               devices, driver.runsHostImages());
      },
      "(usable, reason it is not, [(name, chip, total bytes)], whether it "
      "runs host images) of the CUDA driver, loaded on first call");

  nb::class_<PyDevice>(m, "GpuDevice", "A CUDA device's primary context.")
      .def(nb::new_(&openDevice), nb::arg("ordinal") = 0)
      .def(
          "synchronize",
          [](const PyDevice &self) { self.context->synchronize(); },
          "Waits for every launch on the device to finish");

  nb::class_<PyBuffer>(m, "GpuBuffer", "Device memory.")
      .def_prop_ro("bytes",
                   [](const PyBuffer &self) { return self.buffer->size(); })
      .def("upload", &uploadInto, nb::arg("array"),
           "Copies the C-contiguous array `array` to the start of the "
           "buffer (which must be large enough), after the launches before "
           "it; the buffer then stands for array.size elements")
      .def("download", &download, nb::arg("out"),
           "Copies the buffer's first out.nbytes bytes into the C-contiguous "
           "array `out` (waits for earlier launches)")
      .def("dlpack_view", &dlpackView, nb::arg("shape"), nb::arg("strides"),
           "A view of the buffer's doubles on the device, without a copy, "
           "that DLPack consumers (torch.from_dlpack, cupy.from_dlpack) "
           "take; shape and strides in elements");
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

namespace {

using DoubleArray = nb::ndarray<double, nb::c_contig, nb::device::cpu>;
using MaskArray =
    nb::ndarray<std::uint8_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

/// A GpuSystem with what it needs kept alive: its device's context and the
/// Python GlobalSystem it mirrors. Local derivatives given as NumPy arrays
/// are uploaded for each call (they are computed on the CPU for now).
struct PyGpuSystem {
  std::shared_ptr<CudaContext> context;
  nb::object hostObject;
  const GlobalSystem *host;
  std::unique_ptr<GpuSystem> gpu;
  DeviceBuffer solution;

  /// A device copy of `array` after checking it has `expected` entries.
  DeviceBuffer upload(const DoubleArray &array, std::size_t expected,
                      const char *what, std::size_t energy) const {
    if (array.size() != expected)
      throw std::invalid_argument(
          std::string(what) + " of energy " + std::to_string(energy) + " has " +
          std::to_string(array.size()) + " entries, expected " +
          std::to_string(expected));
    DeviceBuffer buffer(*context, expected * sizeof(double));
    buffer.upload(array.data(), expected * sizeof(double));
    return buffer;
  }

  const GlobalSystem::EnergyMap &structure(std::size_t energy) const {
    return host->energyStructure(energy);
  }

  void add(std::size_t energy, DoubleArray gradients, DoubleArray hessians) {
    const auto &map = structure(energy);
    std::size_t count = map.count, n = map.numParams;
    DeviceBuffer g = upload(gradients, count * n, "the gradients", energy);
    DeviceBuffer h = upload(hessians, count * n * n, "the Hessians", energy);
    gpu->add(energy, g.pointer(), h.pointer());
    // The uploads are freed on return: let the assembly finish first.
    context->synchronize();
  }

  void addFactored(std::size_t energy, DoubleArray gradients, DoubleArray maps,
                   DoubleArray inner, std::int64_t m) {
    const auto &map = structure(energy);
    std::size_t count = map.count, n = map.numParams, k = std::size_t(m);
    DeviceBuffer g = upload(gradients, count * n, "the gradients", energy);
    DeviceBuffer j = upload(maps, count * k * n, "the inner maps", energy);
    DeviceBuffer p = upload(inner, count * k * k, "the inner Hessians", energy);
    gpu->addFactored(energy, g.pointer(), j.pointer(), p.pointer(), m);
    context->synchronize();
  }

  /// The device pointer of `buffer` after checking it holds `expected`
  /// doubles at least.
  static cu::DevicePtr device(const PyBuffer &buffer, std::size_t expected,
                              const char *what, std::size_t energy) {
    if (buffer.buffer->size() < expected * sizeof(double))
      throw std::invalid_argument(
          std::string(what) + " of energy " + std::to_string(energy) +
          ": a device buffer of " + std::to_string(buffer.buffer->size()) +
          " bytes, expected " + std::to_string(expected) + " doubles");
    return buffer.buffer->pointer();
  }

  void addDevice(std::size_t energy, const PyBuffer &gradients,
                 const PyBuffer &hessians) {
    const auto &map = structure(energy);
    std::size_t count = map.count, n = map.numParams;
    gpu->add(energy, device(gradients, count * n, "the gradients", energy),
             device(hessians, count * n * n, "the Hessians", energy));
  }

  void addFactoredDevice(std::size_t energy, const PyBuffer &gradients,
                         const PyBuffer &maps, const PyBuffer &inner,
                         std::int64_t m, bool columnMajor) {
    const auto &map = structure(energy);
    std::size_t count = map.count, n = map.numParams, k = std::size_t(m);
    gpu->addFactored(energy,
                     device(gradients, count * n, "the gradients", energy),
                     device(maps, count * k * n, "the inner maps", energy),
                     device(inner, count * k * k, "the inner Hessians", energy),
                     m, columnMajor);
  }

  void checkSize(const DoubleArray &array) const {
    if (array.size() != std::size_t(gpu->size()))
      throw std::invalid_argument("array of " + std::to_string(array.size()) +
                                  " entries, expected " +
                                  std::to_string(gpu->size()));
  }

  PcgResult solve(DoubleArray out, double tolerance, std::int64_t maxIterations,
                  std::optional<MaskArray> fixed, int checkEvery,
                  ::yasps::runtime::PcgPreconditioner preconditioner,
                  ::yasps::runtime::PcgStopping stopping) {
    checkSize(out);
    PcgOptions options;
    options.preconditioner = preconditioner;
    options.stopping = stopping;
    options.relativeTolerance = tolerance;
    options.maxIterations = maxIterations;
    std::vector<std::uint8_t> mask;
    if (fixed) {
      mask.assign(fixed->data(), fixed->data() + fixed->shape(0));
      options.fixedDofs = &mask;
    }
    // Kept from solve to solve: a Newton loop then allocates nothing.
    if (solution.size() < out.size() * sizeof(double))
      solution = DeviceBuffer(*context, out.size() * sizeof(double));
    PcgResult result;
    {
      nb::gil_scoped_release release;
      result = gpu->solve(solution.pointer(), options, checkEvery);
      solution.download(out.data(), out.size() * sizeof(double));
    }
    return result;
  }

  void multiply(DoubleArray x, DoubleArray y) {
    checkSize(x);
    checkSize(y);
    DeviceBuffer dx(*context, x.size() * sizeof(double));
    dx.upload(x.data(), x.size() * sizeof(double));
    DeviceBuffer dy(*context, y.size() * sizeof(double));
    gpu->multiply(dx.pointer(), dy.pointer());
    dy.download(y.data(), y.size() * sizeof(double));
  }

  /// Seconds per multiply() on device-resident vectors, over `repeats`
  /// back-to-back launches after a warm-up (for benchmarks).
  double timeMultiply(int repeats) {
    if (repeats < 1)
      throw std::invalid_argument("time_multiply needs repeats >= 1");
    std::vector<double> ones(std::size_t(gpu->size()), 1.0);
    DeviceBuffer x(*context, ones.size() * sizeof(double));
    x.upload(ones.data(), ones.size() * sizeof(double));
    DeviceBuffer y(*context, ones.size() * sizeof(double));
    nb::gil_scoped_release release;
    for (int k = 0; k < 3; ++k)
      gpu->multiply(x.pointer(), y.pointer());
    context->synchronize();
    auto start = std::chrono::steady_clock::now();
    for (int k = 0; k < repeats; ++k)
      gpu->multiply(x.pointer(), y.pointer());
    context->synchronize();
    std::chrono::duration<double> spent =
        std::chrono::steady_clock::now() - start;
    return spent.count() / repeats;
  }

  void gradient(DoubleArray out) const {
    checkSize(out);
    std::vector<double> g = gpu->gradient();
    std::copy(g.begin(), g.end(), out.data());
  }
};

} // namespace

void yasps::python::bindGpuSystem(nb::module_ &m, HostSystemOf hostSystemOf) {
  static HostSystemOf systemOf = hostSystemOf;
  nb::class_<PyGpuSystem>(
      m, "GpuSystem",
      "The Newton system of a GlobalSystem on a GPU: assembly, SpMV and "
      "PCG on the device")
      .def(
          "__init__",
          [](PyGpuSystem *self, const PyDevice &device, nb::handle system) {
            const GlobalSystem &host = systemOf(system);
            new (self)
                PyGpuSystem{device.context, nb::borrow(system), &host,
                            std::make_unique<GpuSystem>(*device.context, host)};
          },
          nb::arg("device"), nb::arg("system"),
          "Uploads the structure of `system` (a GlobalSystem) to `device`")
      .def_prop_ro("size",
                   [](const PyGpuSystem &self) { return self.gpu->size(); })
      .def(
          "update_dynamic",
          [](PyGpuSystem &self) { self.gpu->updateDynamic(*self.host); },
          "Uploads the dynamic structure again after system.set_dynamic")
      .def(
          "set_zero", [](PyGpuSystem &self) { self.gpu->setZero(); },
          "Zeroes the gradient and Hessian")
      .def("add", &PyGpuSystem::add, nb::arg("energy"), nb::arg("gradients"),
           nb::arg("hessians"),
           "Adds energy `energy`'s local gradients (count, n) and Hessians "
           "(count, n, n)")
      .def("add_factored", &PyGpuSystem::addFactored, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("maps"), nb::arg("inner"),
           nb::arg("m"),
           "add() with Hessians J^T P J: maps (count, m, n), inner (count, m, "
           "m)")
      .def("add_device", &PyGpuSystem::addDevice, nb::arg("energy"),
           nb::arg("gradients"), nb::arg("hessians"),
           "add() from GpuBuffers already on the device (no copy; the "
           "buffers must live until the device has run the assembly)")
      .def("add_factored_device", &PyGpuSystem::addFactoredDevice,
           nb::arg("energy"), nb::arg("gradients"), nb::arg("maps"),
           nb::arg("inner"), nb::arg("m"), nb::arg("column_major") = false,
           "add_factored() from GpuBuffers; column_major: each J is stored "
           "column-major, as the generated kernels write it")
      .def(
          "synchronize",
          [](const PyGpuSystem &self) { self.context->synchronize(); },
          "Waits for the system's work on the device")
      .def("solve", &PyGpuSystem::solve, nb::arg("out"), nb::arg("tolerance"),
           nb::arg("max_iterations"), nb::arg("fixed").none() = nb::none(),
           nb::arg("check_every") = 8,
           nb::arg("preconditioner") =
               ::yasps::runtime::PcgPreconditioner::BlockJacobi,
           nb::arg("stopping") = ::yasps::runtime::PcgStopping::Residual,
           "Solves H x = g into `out` on the device (block-Jacobi or "
           "multilevel PCG, stopping as the CPU's PCG does); returns a "
           "PcgReport")
      .def("multiply", &PyGpuSystem::multiply, nb::arg("x"), nb::arg("y"),
           "y = H x on the device")
      .def("gradient", &PyGpuSystem::gradient, nb::arg("out"),
           "Copies the assembled gradient into `out`")
      .def("time_multiply", &PyGpuSystem::timeMultiply, nb::arg("repeats"),
           "Seconds per SpMV on device-resident vectors (benchmarks)")
      .def_prop_ro(
          "stored_blocks",
          [](const PyGpuSystem &self) { return self.gpu->storedBlocks(); })
      .def_prop_ro(
          "multiply_bytes",
          [](const PyGpuSystem &self) { return self.gpu->multiplyBytes(); },
          "Bytes one SpMV moves at least: values, block coordinates, x "
          "and y once each");
  m.def(
      "gpu_solver_images",
      [] {
        nb::dict out;
        for (const GpuImage &image : gpuSolverImages())
          out[nb::make_tuple(image.chip, image.format)] =
              nb::bytes(image.bytes->data(), image.bytes->size());
        return out;
      },
      "The GPU solver kernels built into the runtime: {(chip, format): "
      "bytes} (empty without nvcc at build time)");
  m.def("gpu_solver_kernel_names", &gpuSolverKernelNames,
        "The kernels every GPU solver binary defines");
}
