// SocketCAN (Linux): raw CAN sockets with filters, non-blocking I/O with
// poll(), kernel receive timestamps, and error frames decoded into faults.
// Opening reports a missing interface or a kernel without CAN clearly; the
// real-time calls (send, receive) return codes instead of throwing.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace delta::can {

struct Frame {
  std::uint32_t id{0};  // 11-bit, or 29-bit when extended
  bool extended{false};
  bool remote{false};  // RTR
  // An error frame: id holds the CAN_ERR_* class bits. Controllers' drivers
  // make these; on vcan a program may send one (the emulator's fault
  // injection).
  bool error_frame{false};
  std::uint8_t dlc{0};  // 0..8
  std::array<std::uint8_t, 8> data{};
};

// What an error frame says (linux/can/error.h classes), as faults.
struct BusError {
  bool bus_off{false};
  bool error_passive{false};
  bool warning{false};  // error counters above the warning level
  bool lost_arbitration{false};
  bool protocol_violation{false};
  bool no_ack{false};
  bool restarted{false};
  std::uint32_t raw_class{0};  // the CAN_ERR_* bits of the error frame
};

struct Received {
  Frame frame;
  std::chrono::nanoseconds kernel_time{0};  // SO_TIMESTAMPNS, CLOCK_REALTIME
  std::optional<BusError> error;            // set for an error frame
  // Frames this socket had dropped, because its receive buffer was full,
  // when this frame was queued (SO_RXQ_OVFL): drops show on the next frame
  // that gets through after them.
  std::uint32_t socket_drops{0};
};

// Accept frames whose (id & mask) == (filter id & mask).
struct Filter {
  std::uint32_t id{0};
  std::uint32_t mask{0};
  bool extended{false};
};

class CanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class SendResult { kOk, kWouldBlock, kNetworkDown, kError };

class Socket {
 public:
  // Opens a raw socket on `iface`, non-blocking, with kernel timestamps and
  // error frames enabled. No filters: every frame. Throws CanError.
  // receive_buffer_bytes > 0 enlarges the kernel's receive buffer (forced
  // beyond rmem_max when running as root), so a reader can absorb bursts.
  static Socket open(const std::string& iface, const std::vector<Filter>& filters = {},
                     int receive_buffer_bytes = 0);

  Socket(Socket&& other) noexcept;
  Socket& operator=(Socket&& other) noexcept;
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;
  ~Socket();

  SendResult send(const Frame& f);
  // The next frame, if one is waiting.
  std::optional<Received> receive();
  // Waits until a frame can be read or the timeout passes.
  bool wait_readable(std::chrono::milliseconds timeout);
  // Whether own sent frames are received back on this socket (default off).
  void set_receive_own(bool on);

  int fd() const { return fd_; }
  const std::string& interface_name() const { return iface_; }

 private:
  Socket(int fd, std::string iface) : fd_(fd), iface_(std::move(iface)) {}
  int fd_{-1};
  std::string iface_;
};

// Decodes an error frame's id and data (linux/can/error.h).
BusError decode_error_frame(std::uint32_t can_id, const std::array<std::uint8_t, 8>& data);

// "0x181 [8] 01 02 ..." for messages.
std::string describe(const Frame& f);

}  // namespace delta::can
