// How late a real-time thread wakes up: a measure of the CPU time the
// machine (here the HIL VM's emulated CPUs) gives a SCHED_FIFO thread, taken
// beside the program under test and independent of it. Inside the VM a
// FIFO thread above every other one wakes on time unless the host takes the
// VM's CPUs away (its threads beside other work on the same cores): then
// every real-time thread in the VM wakes late, delta_fw's loop as well, and
// no rate bar on that loop measures delta_fw.
#pragma once

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <string>
#include <thread>
#include <vector>

namespace hil {

class WakeUpProbe {
 public:
  using Clock = std::chrono::steady_clock;
  struct Wake {
    Clock::time_point due;
    std::chrono::nanoseconds late;
  };

  // Wakes every period at SCHED_FIFO fifo_priority until destroyed or
  // stopped; keeps at most max_wakes wakes (no allocation while it runs).
  WakeUpProbe(int fifo_priority, std::chrono::microseconds period, std::size_t max_wakes)
      : period_(period) {
    wakes_.reserve(max_wakes);
    thread_ = std::thread([this, fifo_priority] { run(fifo_priority); });
  }
  ~WakeUpProbe() { stop(); }
  WakeUpProbe(const WakeUpProbe&) = delete;
  WakeUpProbe& operator=(const WakeUpProbe&) = delete;

  // Joins the thread; afterwards wakes() and error() may be read.
  void stop() {
    stop_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  const std::vector<Wake>& wakes() const { return wakes_; }
  // Empty, or why the probe could not run at its priority.
  const std::string& error() const { return error_; }

  struct Count {
    std::size_t wakes{0};
    std::size_t late{0};  // of them, later than the limit asked for
  };
  // The wakes due in [from, to), and how many of them came later than limit.
  Count later_than(std::chrono::nanoseconds limit, Clock::time_point from,
                   Clock::time_point to) const {
    Count c;
    for (const Wake& w : wakes_) {
      if (w.due < from || w.due >= to) continue;
      ++c.wakes;
      if (w.late > limit) ++c.late;
    }
    return c;
  }

 private:
  void run(int fifo_priority) {
    const sched_param param{fifo_priority};
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) != 0) {
      error_ = "SCHED_FIFO priority " + std::to_string(fifo_priority) + " refused";
      return;
    }
    Clock::time_point due = Clock::now();
    while (!stop_.load() && wakes_.size() < wakes_.capacity()) {
      due += period_;
      const auto since_epoch = due.time_since_epoch();
      const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(since_epoch);
      const timespec at{static_cast<time_t>(seconds.count()),
                        static_cast<long>((since_epoch - seconds).count())};
      // steady_clock is CLOCK_MONOTONIC on Linux.
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr) != 0) {
      }
      const Clock::time_point woke = Clock::now();
      wakes_.push_back({due, woke - due});
      if (woke - due > period_) due = woke;  // a missed wake is not made up in a burst
    }
  }

  std::chrono::nanoseconds period_;
  std::atomic<bool> stop_{false};
  std::vector<Wake> wakes_;
  std::string error_;
  std::thread thread_;
};

}  // namespace hil
