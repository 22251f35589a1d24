#include "host_id/parallel.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "address_sanitizer.hpp"

namespace host_id {
namespace {

// Every task once, whatever the numbers of tasks and workers.
TEST(RunTasks, RunsEveryTaskOnceOnAtMostTheWorkersAsked) {
  for (const std::size_t tasks : {0u, 1u, 2u, 7u, 64u}) {
    for (const std::size_t workers : {1u, 2u, 3u, 8u}) {
      std::vector<std::atomic<int>> runs(tasks);
      std::mutex m;
      std::set<std::size_t> worker_ids;
      run_tasks(tasks, workers, [&](std::size_t w, std::size_t k) {
        ++runs[k];
        const std::lock_guard<std::mutex> lock(m);
        worker_ids.insert(w);
      });
      for (std::size_t k = 0; k < tasks; ++k) {
        EXPECT_EQ(runs[k].load(), 1) << "task " << k << " of " << tasks << ", " << workers;
      }
      for (const std::size_t w : worker_ids) EXPECT_LT(w, std::min(workers, tasks));
    }
  }
}

// One worker: the tasks run on the calling thread, in order.
TEST(RunTasks, OneWorkerRunsInOrderOnTheCaller) {
  std::vector<std::size_t> order;
  const auto caller = std::this_thread::get_id();
  run_tasks(5, 1, [&](std::size_t w, std::size_t k) {
    EXPECT_EQ(w, 0u);
    EXPECT_EQ(std::this_thread::get_id(), caller);
    order.push_back(k);
  });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
}

// Two workers: neither is the caller (which only waits, so that the kernel
// runs the new threads on the CPUs it has, not behind the caller), and
// they run at the same time: each of two tasks waits for the other to have
// started, which only two threads at once get past.
TEST(RunTasks, MoreWorkersAreNewThreadsRunningTogether) {
  const auto caller = std::this_thread::get_id();
  std::atomic<int> started{0};
  std::atomic<bool> met_in_time{true};
  std::vector<std::thread::id> ids(2);
  run_tasks(2, 2, [&](std::size_t, std::size_t k) {
    ids[k] = std::this_thread::get_id();
    ++started;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (started.load() < 2) {
      if (std::chrono::steady_clock::now() > deadline) {
        met_in_time = false;
        return;
      }
      std::this_thread::yield();
    }
  });
  EXPECT_TRUE(met_in_time.load());
  EXPECT_NE(ids[0], caller);
  EXPECT_NE(ids[1], caller);
  EXPECT_NE(ids[0], ids[1]);
}

// A task's exception reaches the caller, on one thread or many, once every
// worker has stopped (the others' tasks still hold their references). On
// one thread the tasks after it do not run.
TEST(RunTasks, RethrowsATasksException) {
  for (const std::size_t workers : {1u, 2u, 4u}) {
    std::atomic<int> ran{0};
    try {
      run_tasks(1000, workers, [&](std::size_t, std::size_t k) {
        ++ran;
        if (k == 3) throw std::runtime_error("task 3 failed");
      });
      ADD_FAILURE() << workers << " workers: no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "task 3 failed") << workers << " workers";
    }
    if (workers == 1) {
      EXPECT_EQ(ran.load(), 4);
    }
  }
}

#if !DELTA_ADDRESS_SANITIZER  // the sanitizer's own mappings need address space
// In a child process: with no address space left for a thread's stack,
// runs 8 tasks on 4 workers and exits 0 if every task ran.
[[noreturn]] void run_without_room_for_threads() {
  long pages = 0;
  std::ifstream("/proc/self/statm") >> pages;
  const auto in_use = static_cast<rlim_t>(pages) * static_cast<rlim_t>(sysconf(_SC_PAGESIZE));
  const rlim_t room = in_use + (rlim_t{2} << 20);  // an 8 MiB stack does not fit
  const rlimit limit{room, room};
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::_Exit(3);
  std::atomic<int> ran{0};
  run_tasks(8, 4, [&](std::size_t, std::size_t) { ++ran; });
  std::_Exit(ran.load() == 8 ? 0 : 1);
}

// Where no thread can be started, the caller does the work itself, and
// every task runs.
TEST(RunTasks, WorksOnWhereNoThreadCanBeStarted) {
  EXPECT_EXIT(run_without_room_for_threads(), ::testing::ExitedWithCode(0), "");
}
#endif

TEST(WorkersFor, AtLeastOneAtMostAsked) {
  EXPECT_EQ(workers_for(10, 4, 100), 1u);
  EXPECT_EQ(workers_for(250, 4, 100), 2u);
  EXPECT_EQ(workers_for(1000000, 4, 100), 4u);
  EXPECT_GE(workers_for(1000000, 0, 100), 1u);
}

}  // namespace
}  // namespace host_id
