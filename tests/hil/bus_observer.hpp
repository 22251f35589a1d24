// Every frame on the HIL test's vcan bus, read by a thread from a socket
// opened before the programs start, and what the pipeline tests read from
// those frames.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "delta/can/socketcan.hpp"

namespace hil {

class BusObserver {
 public:
  BusObserver();
  ~BusObserver() { stop(); }
  // What arrived so far, while it keeps listening.
  std::vector<delta::can::Frame> snapshot();
  std::vector<delta::can::Frame> stop();
  // Each frame's kernel receive time (CLOCK_REALTIME), after stop().
  const std::vector<std::chrono::nanoseconds>& kernel_times() const { return times_; }

 private:
  void keep(const delta::can::Received& r);
  std::vector<std::chrono::nanoseconds> times_;
  delta::can::Socket socket_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<delta::can::Frame> frames_;
};

// The first two data bytes, little-endian (a controlword or statusword).
std::uint16_t u16(const delta::can::Frame& f);

// Whether each drive's latest TPDO1 on the bus says operation enabled.
bool all_drives_enabled(const std::vector<delta::can::Frame>& frames);

std::uint64_t count_frames(const std::vector<delta::can::Frame>& frames, std::uint32_t id);

}  // namespace hil
