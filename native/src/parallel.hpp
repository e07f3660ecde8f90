// Work spread over threads, for the jobs that split (FK by frames, IK by
// independent groups of effectors). Internal to native/src.
#pragma once

#include <algorithm>
#include <atomic>
#include <system_error>
#include <thread>
#include <vector>

namespace motionkit::internal {

// task(i) for every i in [0, count), on up to `threads` threads counting the
// calling one; each thread takes the next task nobody has started, so long
// tasks listed first balance best. When a thread cannot start, the threads
// that did (at least the calling one) run the rest. task must not throw.
template <typename Task>
void ParallelFor(int count, int threads, const Task& task) {
  std::atomic<int> next{0};
  const auto work = [&] {
    for (int i = next.fetch_add(1); i < count; i = next.fetch_add(1)) task(i);
  };
  std::vector<std::thread> workers;
  const int extra = std::max(0, std::min(threads, count) - 1);
  workers.reserve(static_cast<std::size_t>(extra));
  try {
    for (int t = 0; t < extra; ++t) workers.emplace_back(work);
  } catch (const std::system_error&) {
    // Out of threads: the ones running share what is left.
  }
  work();
  for (std::thread& worker : workers) worker.join();
}

}  // namespace motionkit::internal
