// The control loop allocates nothing: the CANopen master's cyclic calls
// (on_frame, read_feedback) record what went wrong as facts, and words are
// made only when last_problem() is asked, outside the loop. This program
// replaces the global operator new to count allocations, so it is a test
// program of its own.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "delta/can/protocol.hpp"
#include "in_process_rig.hpp"

namespace {
std::atomic<long> g_allocations{0};

// malloc and free behind calls the compiler does not look into: GCC 12
// otherwise takes the replaced operator delete's free() for a mismatch with
// operator new (-Wmismatched-new-delete), which it is not.
[[gnu::noinline]] void* take_memory(std::size_t size) {
  return std::malloc(size == 0 ? 1 : size);
}
[[gnu::noinline]] void give_back(void* p) {
  std::free(p);
}
}  // namespace

void* operator new(std::size_t size) {
  ++g_allocations;
  if (void* p = take_memory(size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  give_back(p);
}
void operator delete(void* p, std::size_t) noexcept {
  give_back(p);
}

namespace fw_linux {
namespace {

namespace p = delta::can::protocol;

// One cycle with the master's calls counted apart from the rig's own work
// (the emulator and the frame queues allocate; they are not the controller).
// `edit` may change, drop or hold back the drives' answers before the
// master sees them. Returns the allocations made inside the master's calls.
template <class Edit>
long counted_cycle(Rig& rig, Edit edit) {
  long inside = 0;
  const auto count = [&](auto&& call) {
    const long before = g_allocations.load();
    call();
    inside += g_allocations.load() - before;
  };
  const auto deliver = [&](std::vector<delta::can::Frame> frames) {
    for (const auto& f : frames) {
      delta::can::Received r;
      r.frame = f;
      count([&] { rig.master.on_frame(r, 0); });
    }
  };
  std::vector<delta::can::Frame> early(rig.bus.to_master_.begin(), rig.bus.to_master_.end());
  rig.bus.to_master_.clear();
  deliver(early);
  // begin_cycle() sends the SYNC through the rig's sink, which queues the
  // emulator's answers (allocating now and then): not counted.
  rig.master.begin_cycle(0);
  std::vector<delta::can::Frame> answers(rig.bus.to_master_.begin(), rig.bus.to_master_.end());
  rig.bus.to_master_.clear();
  std::vector<delta::can::Frame> late;
  edit(answers, late);
  deliver(answers);
  count([&] { rig.master.end_window(); });
  deliver(late);
  std::array<fw::DriveFeedback, 3> feedback{};
  count([&] { rig.master.read_feedback(feedback); });
  rig.master.send_commands();
  return inside;
}

bool from(const delta::can::Frame& f, const p::Message& m, std::uint8_t node) {
  return f.id == p::cob_id(m, node);
}

TEST(CanopenMasterAllocationTest, CyclicProblemsAreRecordedWithoutAllocatingAndWordedOnRequest) {
  Rig rig;
  for (int n = 0; n < 50 && rig.controller.state() != fw::State::kReady; ++n) rig.cycle();
  ASSERT_EQ(rig.controller.state(), fw::State::kReady) << rig.master.last_problem();
  for (int i = 0; i < 20; ++i) rig.cycle();

  // A TPDO1 of the wrong length from node 2.
  EXPECT_EQ(counted_cycle(rig,
                          [](auto& answers, auto&) {
                            for (auto& f : answers) {
                              if (from(f, p::kTpdo1, 2)) f.dlc = 5;
                            }
                          }),
            0);
  EXPECT_EQ(rig.master.last_problem(), "node 2: TPDO1 0x182 has 5 bytes, expected 8");

  // Node 1's TPDO1 after the cycle's deadline.
  EXPECT_EQ(counted_cycle(rig,
                          [](auto& answers, auto& late) {
                            std::erase_if(answers, [&](const delta::can::Frame& f) {
                              if (!from(f, p::kTpdo1, 1)) return false;
                              late.push_back(f);
                              return true;
                            });
                          }),
            0);
  EXPECT_EQ(rig.master.last_problem(), "node 1: TPDO1 0x181 arrived after the cycle's deadline");

  // Node 3 falls silent: no sample (TPDO1) first, then no heartbeat for longer than
  // the timeout (150 ms at 500 Hz: 75 cycles).
  const auto silence_node_3 = [](auto& answers, auto&) {
    std::erase_if(answers, [](const delta::can::Frame& f) { return (f.id & 0x7F) == 3; });
  };
  EXPECT_EQ(counted_cycle(rig, silence_node_3), 0);
  EXPECT_NE(
      rig.master.last_problem().find("node 3: no sample (TPDO1 0x183) answered the SYNC of cycle"),
      std::string::npos)
      << rig.master.last_problem();
  long allocations = 0;
  for (int i = 0; i < 100; ++i) allocations += counted_cycle(rig, silence_node_3);
  EXPECT_EQ(allocations, 0);
  const std::string problem = rig.master.last_problem();
  EXPECT_EQ(problem.rfind("node 3: no heartbeat for ", 0), 0u) << problem;
  EXPECT_NE(problem.find("ms (timeout 150 ms)"), std::string::npos) << problem;

  // The counter itself counts: asking for the words allocates.
  const long before = g_allocations.load();
  EXPECT_FALSE(rig.master.last_problem().empty());
  EXPECT_GT(g_allocations.load(), before);
}

}  // namespace
}  // namespace fw_linux
