// One SDO transfer at a time with one node over a SocketCAN socket:
// common's client (delta/can/sdo.hpp), its frames paced by the socket (a
// full transmit queue, ENOBUFS or EAGAIN, waits for room instead of
// failing), its timeout, and what the transfer cost. For host tools
// (host_id sdo, host_id flash) and tests; not for the control loop.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "delta/can/sdo.hpp"
#include "delta/can/socketcan.hpp"

namespace delta::can {

struct SdoOutcome {
  sdo::AbortCode abort{sdo::kNoAbort};  // 0: done
  bool by_server{false};                // the node aborted (else this side)
  bool bus_blocked{false};              // the socket took no frame for the timeout
  std::uint32_t bytes{0};               // uploaded, or downloaded
  std::uint64_t frames_sent{0};
  std::uint64_t frames_received{0};
  std::uint64_t elapsed_us{0};
  bool ok() const { return abort == sdo::kNoAbort; }
};

class SdoChannel {
 public:
  // `socket` should receive the node's SDO responses (0x580 + node); others
  // are ignored.
  SdoChannel(Socket& socket, std::uint8_t node, std::chrono::milliseconds timeout,
             std::uint8_t block_size = sdo::kMaxBlockSize);

  // Reads index:subindex; `data` holds what came (at most max_bytes).
  SdoOutcome upload(std::uint16_t index, std::uint8_t subindex, std::vector<std::uint8_t>& data,
                    sdo::Transfer transfer, std::size_t max_bytes = std::size_t{1} << 24);
  SdoOutcome download(std::uint16_t index, std::uint8_t subindex,
                      std::span<const std::uint8_t> data, sdo::Transfer transfer);

  // Sends an abort for index:subindex: a transfer the node still holds for
  // a client that went away (killed mid-transfer) ends at once, not at the
  // node's timeout. Harmless when none is in progress.
  void abort(std::uint16_t index, std::uint8_t subindex, sdo::AbortCode code);

  // Called as a transfer advances, with the bytes done so far.
  void set_progress(std::function<void(std::uint32_t bytes)> progress) {
    progress_ = std::move(progress);
  }

  // "node 16, 0x1008:00: the node aborted the transfer: 0x06020000 (object
  // does not exist in the object dictionary)", for messages.
  std::string describe(std::uint16_t index, std::uint8_t subindex, const SdoOutcome& o) const;

 private:
  SdoOutcome run(sdo::Client& client);

  Socket& socket_;
  std::uint8_t node_;
  std::uint32_t timeout_us_;
  std::uint8_t block_size_;
  std::function<void(std::uint32_t)> progress_;
};

// The filter that gives a socket a node's SDO responses.
Filter sdo_response_filter(std::uint8_t node);

}  // namespace delta::can
