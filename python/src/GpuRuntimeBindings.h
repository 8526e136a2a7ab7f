//===- GpuRuntimeBindings.h - the CUDA runtime for Python -------*- C++ -*-===//

#ifndef YASPS_PYTHON_GPURUNTIMEBINDINGS_H
#define YASPS_PYTHON_GPURUNTIMEBINDINGS_H

#include <nanobind/nanobind.h>

namespace yasps::runtime {
class GlobalSystem;
}

namespace yasps::python {

/// Adds CudaError, cuda_status, GpuDevice, GpuBuffer, GpuModule and the
/// gpu_* functions to the native module.
void bindGpuRuntime(nanobind::module_ &m);

/// The runtime system behind a Python GlobalSystem object.
using HostSystemOf = const runtime::GlobalSystem &(*)(nanobind::handle);

/// Adds GpuSystem: the Newton system of a Python GlobalSystem (found by
/// `hostSystemOf`) on a GpuDevice. Call after bindGpuRuntime.
void bindGpuSystem(nanobind::module_ &m, HostSystemOf hostSystemOf);

} // namespace yasps::python

#endif // YASPS_PYTHON_GPURUNTIMEBINDINGS_H
