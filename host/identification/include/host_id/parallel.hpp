// Work shared out over threads, for the fit's passes over long logs.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <system_error>
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

// Runs task(worker, k) once for every k in [0, tasks), on `workers` threads,
// each taking the next task left; `worker` lets a task use its thread's own
// buffers. With one worker, on this thread. With more, every worker is a new
// thread and this one only waits: Linux places a new thread on the CPU of
// the thread that made it, and while that thread kept working the new one
// waited there for a millisecond or more with the other CPU idle (measured
// on a two-CPU machine: two tasks of 1 ms took 2.0 ms that way, 1.1 ms
// with this one waiting). Where the system will not start another thread,
// this one works in its place. The first exception a task throws is
// rethrown here once every worker has stopped; the workers take no new task
// after it.
template <class Task>
void run_tasks(std::size_t tasks, std::size_t workers, const Task& task) {
  workers = std::min(workers, tasks);
  if (workers <= 1) {
    for (std::size_t k = 0; k < tasks; ++k) task(std::size_t{0}, k);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr failed;
  std::atomic<bool> any_failed{false};
  const auto work = [&](std::size_t worker) {
    for (std::size_t k = next++; k < tasks && !any_failed.load(); k = next++) {
      try {
        task(worker, k);
      } catch (...) {
        if (!any_failed.exchange(true)) failed = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(workers);
  try {
    for (std::size_t w = 0; w < workers; ++w) pool.emplace_back(work, w);
  } catch (const std::system_error&) {
    work(pool.size());  // no thread to be had: this one takes that worker's place
  }
  for (std::thread& t : pool) t.join();
  if (failed) std::rethrow_exception(failed);
}

// Runs a() and b() side by side, on two threads where `threads` (0: one per
// core) allows, else one after the other; as run_tasks, a task's exception
// is rethrown here.
template <class A, class B>
void run_both(unsigned threads, const A& a, const B& b) {
  run_tasks(2, workers_for(2, threads, 1), [&](std::size_t, std::size_t k) {
    if (k == 0) {
      a();
    } else {
      b();
    }
  });
}

}  // namespace host_id
