//===- ThreadPools.h - the runtime's thread pools for Python ----*- C++ -*-===//

#ifndef YASPS_PYTHON_THREADPOOLS_H
#define YASPS_PYTHON_THREADPOOLS_H

#include "yasps/Runtime/Support/ThreadPool.h"

namespace yasps::python {

/// The pool of `threads` workers, created on first use and kept for the
/// process (0: the runtime's default pool). Python passes a thread count per
/// call; pools are too costly to create per call. More than kMaxThreads is
/// std::invalid_argument (an ArgumentError in Python): the system runs out
/// of threads before, and the error would not say why.
inline constexpr unsigned kMaxThreads = 1024;
runtime::ThreadPool &poolFor(unsigned threads);

} // namespace yasps::python

#endif // YASPS_PYTHON_THREADPOOLS_H
