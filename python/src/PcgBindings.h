//===- PcgBindings.h - PCG's options and reports for Python -----*- C++ -*-===//

#ifndef YASPS_PYTHON_PCGBINDINGS_H
#define YASPS_PYTHON_PCGBINDINGS_H

#include <nanobind/nanobind.h>

namespace yasps::python {

/// Adds PcgStopping, PcgStop and PcgReport (a solve's PcgResult, read-only)
/// to the native module: the CPU and GPU systems' solve() return PcgReport.
void bindPcg(nanobind::module_ &m);

} // namespace yasps::python

#endif // YASPS_PYTHON_PCGBINDINGS_H
