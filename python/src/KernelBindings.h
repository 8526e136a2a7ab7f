//===- KernelBindings.h - launching compiled CPU kernels from Python
//-------===//
//
// The compiler module JIT-compiles CPU kernels and hands out their entry
// points; the runtime module launches them on its thread pools. One module
// owns the pools: two copies (one per module) kept threads polling after
// their jobs on both sides, stealing each other's cores.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_PYTHON_KERNELBINDINGS_H
#define YASPS_PYTHON_KERNELBINDINGS_H

#include <nanobind/nanobind.h>

namespace yasps::python {

void bindKernelLaunch(nanobind::module_ &m);

} // namespace yasps::python

#endif // YASPS_PYTHON_KERNELBINDINGS_H
