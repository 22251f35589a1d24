// Work shared out over threads, for the fit's passes over long logs.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <thread>
#include <vector>

namespace host_id {

// How many threads for `items` items when a thread should have at least
// `per_thread` of them to pay for its start-up: at most `threads` (0: one
// per core), at least one.
inline std::size_t workers_for(std::size_t items, unsigned threads, std::size_t per_thread) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  return std::min<std::size_t>(threads, std::max<std::size_t>(1, items / per_thread));
}

// Runs task(worker, k) once for every k in [0, tasks), on `workers` threads
// (this one is worker 0), each taking the next task left; `worker` lets a
// task use its thread's own buffers.
template <class Task>
void run_tasks(std::size_t tasks, std::size_t workers, const Task& task) {
  std::atomic<std::size_t> next{0};
  const auto work = [&](std::size_t worker) {
    for (std::size_t k = next++; k < tasks; k = next++) task(worker, k);
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < std::min(workers, tasks); ++w) pool.emplace_back(work, w);
  work(0);
  for (std::thread& t : pool) t.join();
}

}  // namespace host_id
