//===- ContactBindings.h - the runtime's narrow phase and CCD ---*- C++ -*-===//

#ifndef YASPS_PYTHON_CONTACTBINDINGS_H
#define YASPS_PYTHON_CONTACTBINDINGS_H

#include <nanobind/nanobind.h>

namespace yasps::python {

/// Adds ContactMesh and ContactCandidates (a step's broad phase) with the
/// collision set and additive CCD over them to the native module.
void bindContact(nanobind::module_ &m);

} // namespace yasps::python

#endif // YASPS_PYTHON_CONTACTBINDINGS_H
