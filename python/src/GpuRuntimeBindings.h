//===- GpuRuntimeBindings.h - the CUDA runtime for Python -------*- C++ -*-===//

#ifndef YASPS_PYTHON_GPURUNTIMEBINDINGS_H
#define YASPS_PYTHON_GPURUNTIMEBINDINGS_H

#include <nanobind/nanobind.h>

namespace yasps::python {

/// Adds CudaError, cuda_status, GpuDevice, GpuBuffer, GpuModule and the
/// gpu_* functions to the native module.
void bindGpuRuntime(nanobind::module_ &m);

} // namespace yasps::python

#endif // YASPS_PYTHON_GPURUNTIMEBINDINGS_H
