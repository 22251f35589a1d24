#include "bus_observer.hpp"

#include <algorithm>

#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"
#include "vcan_interface.hpp"

namespace hil {

namespace p = delta::can::protocol;
namespace cia = delta::can::cia402;
using delta::can::Frame;
using namespace std::chrono_literals;

BusObserver::BusObserver() : socket_(delta::can::Socket::open(vcan_interface(), {}, 32 << 20)) {
  thread_ = std::thread([this] {
    while (!stop_.load()) {
      if (!socket_.wait_readable(20ms)) continue;
      std::lock_guard<std::mutex> lock(mutex_);
      while (auto r = socket_.receive()) keep(*r);
    }
  });
}

std::vector<Frame> BusObserver::snapshot() {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_;
}

std::vector<Frame> BusObserver::stop() {
  if (thread_.joinable()) {
    stop_.store(true);
    thread_.join();
    while (auto r = socket_.receive()) keep(*r);
  }
  return frames_;
}

void BusObserver::keep(const delta::can::Received& r) {
  frames_.push_back(r.frame);
  times_.push_back(r.kernel_time);
}

std::uint16_t u16(const Frame& f) {
  return static_cast<std::uint16_t>(f.data[0] | (f.data[1] << 8));
}

bool all_drives_enabled(const std::vector<Frame>& frames) {
  int on = 0;
  for (std::uint8_t node = 1; node <= 3; ++node) {
    for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
      if (it->id == p::cob_id(p::kTpdo1, node)) {
        on += cia::decode_statusword(u16(*it)) == cia::State::kOperationEnabled;
        break;
      }
    }
  }
  return on == 3;
}

std::uint64_t count_frames(const std::vector<Frame>& frames, std::uint32_t id) {
  return static_cast<std::uint64_t>(
      std::count_if(frames.begin(), frames.end(), [id](const Frame& f) { return f.id == id; }));
}

}  // namespace hil
