//===- ErrorTranslation.cpp - the runtime's C++ errors as yasps errors ----===//

#include "ErrorTranslation.h"

#include <stdexcept>

namespace nb = nanobind;

namespace {
/// The Python classes errors become; alive for the interpreter's life (a
/// translator may run until it ends).
struct ErrorClasses {
  PyObject *argument;
  PyObject *indexRange;
};
} // namespace

void yasps::python::translateRuntimeErrors() {
  // yasps.errors imports nothing of the extensions: no import cycle.
  nb::module_ errors = nb::module_::import_("yasps.errors");
  // The references are kept (released, never decremented): the classes
  // must outlive every translation.
  nb::object argument = errors.attr("ArgumentError");
  nb::object indexRange = errors.attr("IndexRangeError");
  auto *classes =
      new ErrorClasses{argument.release().ptr(), indexRange.release().ptr()};
  nb::register_exception_translator(
      [](const std::exception_ptr &p, void *payload) {
        const auto *to = static_cast<const ErrorClasses *>(payload);
        try {
          std::rethrow_exception(p);
        } catch (const std::invalid_argument &e) {
          PyErr_SetString(to->argument, e.what());
        } catch (const std::out_of_range &e) {
          PyErr_SetString(to->indexRange, e.what());
        } catch (const std::length_error &e) {
          // A size past what a container can hold: a size given wrong.
          PyErr_SetString(to->argument, e.what());
        }
      },
      classes);
}
