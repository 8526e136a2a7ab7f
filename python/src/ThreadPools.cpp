//===- ThreadPools.cpp - the runtime's thread pools for Python ------------===//

#include "ThreadPools.h"

#include <map>
#include <memory>
#include <mutex>

using namespace yasps;

runtime::ThreadPool &yasps::python::poolFor(unsigned threads) {
  if (threads == 0)
    return runtime::defaultThreadPool();
  static std::mutex lock;
  static std::map<unsigned, std::unique_ptr<runtime::ThreadPool>> pools;
  std::lock_guard<std::mutex> guard(lock);
  auto &pool = pools[threads];
  if (!pool)
    pool = std::make_unique<runtime::ThreadPool>(threads);
  return *pool;
}
