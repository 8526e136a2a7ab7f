//===- ErrorTranslation.h - the runtime's C++ errors as yasps errors ------===//
//
// The runtime checks what it is given and throws the standard exceptions
// (std::invalid_argument for a bad argument, std::out_of_range for an index
// or size past its end). Reaching Python through nanobind's defaults they
// were bare ValueErrors and IndexErrors; every error a user's mistake raises
// is a YaspsError (docs/python.md, "Errors"), so they are translated to the
// package's own classes, which remain ValueError and IndexError subclasses.
//
//===----------------------------------------------------------------------===//

#ifndef YASPS_PYTHON_ERRORTRANSLATION_H
#define YASPS_PYTHON_ERRORTRANSLATION_H

#include <nanobind/nanobind.h>

namespace yasps::python {

/// Registers the translation of std::invalid_argument and std::length_error
/// (a size past what a container holds) to yasps.errors.ArgumentError and
/// of std::out_of_range to yasps.errors.IndexRangeError for every function of the running
/// interpreter's extensions (nanobind's translators are global).
void translateRuntimeErrors();

} // namespace yasps::python

#endif // YASPS_PYTHON_ERRORTRANSLATION_H
