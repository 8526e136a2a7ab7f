//===- ThreadPools.cpp - the runtime's thread pools for Python ------------===//

#include "ThreadPools.h"

#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

using namespace yasps;

runtime::ThreadPool &yasps::python::poolFor(unsigned threads) {
  // One pool per size: two pools of the same size would each keep threads
  // polling after their jobs and steal the cores the other one runs on.
  // The default pool's size, read once: defaultThreadCount() reads the
  // environment and the online CPUs (a file), which cost 3% of a contact
  // frame when asked at every kernel launch.
  static const unsigned defaultCount = runtime::defaultThreadCount();
  if (threads == 0 || threads == defaultCount)
    return runtime::defaultThreadPool();
  if (threads > kMaxThreads)
    throw std::invalid_argument("a thread count of " + std::to_string(threads) +
                                ": at most " + std::to_string(kMaxThreads));
  static std::mutex lock;
  static std::map<unsigned, std::unique_ptr<runtime::ThreadPool>> pools;
  std::lock_guard<std::mutex> guard(lock);
  auto &pool = pools[threads];
  if (!pool)
    pool = std::make_unique<runtime::ThreadPool>(threads);
  return *pool;
}
