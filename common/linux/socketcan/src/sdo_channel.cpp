#include "delta/can/sdo_channel.hpp"

#include <poll.h>

#include <cstdio>

#include "delta/can/protocol.hpp"
#include "delta/monotonic_clock.hpp"

namespace delta::can {

namespace p = protocol;

Filter sdo_response_filter(std::uint8_t node) {
  return {p::cob_id(p::kSdoTx, node), p::kStandardIdMask, false};
}

SdoChannel::SdoChannel(Socket& socket, std::uint8_t node, std::chrono::milliseconds timeout,
                       std::uint8_t block_size)
    : socket_(socket),
      node_(node),
      timeout_us_(static_cast<std::uint32_t>(timeout.count() * 1000)),
      block_size_(block_size) {}

SdoOutcome SdoChannel::upload(std::uint16_t index, std::uint8_t subindex,
                              std::vector<std::uint8_t>& data, sdo::Transfer transfer,
                              std::size_t max_bytes) {
  data.assign(max_bytes, 0);
  sdo::Client client(timeout_us_, block_size_);
  client.upload(index, subindex, data, transfer, monotonic_us());
  SdoOutcome o = run(client);
  data.resize(o.ok() ? client.uploaded_size() : 0);
  o.bytes = static_cast<std::uint32_t>(data.size());
  return o;
}

SdoOutcome SdoChannel::download(std::uint16_t index, std::uint8_t subindex,
                                std::span<const std::uint8_t> data, sdo::Transfer transfer) {
  sdo::Client client(timeout_us_, block_size_);
  client.download(index, subindex, data, transfer, monotonic_us());
  SdoOutcome o = run(client);
  o.bytes = o.ok() ? static_cast<std::uint32_t>(data.size()) : 0;
  return o;
}

void SdoChannel::abort(std::uint16_t index, std::uint8_t subindex, sdo::AbortCode code) {
  Frame f;
  f.id = p::cob_id(p::kSdoRx, node_);
  f.dlc = 8;
  f.data = sdo::abort_transfer(index, subindex, code);
  const SendResult sent = socket_.send(f);
  if (sent == SendResult::kNetworkDown || sent == SendResult::kError) {
    throw CanError(socket_.interface_name() + ": cannot send to node " + std::to_string(node_) +
                   " (the interface is down?)");
  }
}

// Sends what the client has while the socket takes it, reads the node's
// answers, runs the client's clock; until the transfer ends and its last
// frame (a confirmation or an abort) is on the bus.
SdoOutcome SdoChannel::run(sdo::Client& client) {
  SdoOutcome o;
  const std::uint64_t start = monotonic_us();
  std::uint64_t full_since = 0;  // the transmit queue has been full since
  std::uint32_t reported = 0;
  for (;;) {
    bool queue_full = false;
    sdo::Payload p;
    while (client.pending(p)) {
      Frame f;
      f.id = p::cob_id(p::kSdoRx, node_);
      f.dlc = 8;
      f.data = p;
      const SendResult r = socket_.send(f);
      if (r == SendResult::kWouldBlock) {
        queue_full = true;
        break;
      }
      if (r != SendResult::kOk)
        throw CanError(socket_.interface_name() + ": cannot send to node " + std::to_string(node_) +
                       " (the interface is down?)");
      client.sent(monotonic_us());
      ++o.frames_sent;
    }
    if (client.status() != sdo::ClientStatus::kBusy && !client.pending(p)) break;
    // A queue that stays full (no node acknowledges, the bus is off) ends
    // the transfer after the timeout instead of waiting for ever.
    const std::uint64_t now = monotonic_us();
    full_since = queue_full ? (full_since == 0 ? now : full_since) : 0;
    if (full_since != 0 && now - full_since > timeout_us_) {
      o.abort = sdo::kAbortTimeout;
      o.bus_blocked = true;
      o.elapsed_us = now - start;
      return o;
    }
    pollfd pfd{socket_.fd(), static_cast<short>(POLLIN | (queue_full ? POLLOUT : 0)), 0};
    ::poll(&pfd, 1, 5);
    while (auto r = socket_.receive()) {
      if (r->error || r->frame.id != p::cob_id(p::kSdoTx, node_) || r->frame.dlc != 8) continue;
      ++o.frames_received;
      client.on_frame(r->frame.data, monotonic_us());
    }
    client.tick(monotonic_us());
    if (progress_ && client.transferred() != reported) progress_(reported = client.transferred());
  }
  o.abort = client.status() == sdo::ClientStatus::kDone ? sdo::kNoAbort : client.abort_code();
  o.by_server = client.aborted_by_server();
  o.elapsed_us = monotonic_us() - start;
  return o;
}

std::string SdoChannel::describe(std::uint16_t index, std::uint8_t subindex,
                                 const SdoOutcome& o) const {
  char head[48];
  std::snprintf(head, sizeof head, "node %u, 0x%04X:%02X: ", unsigned{node_}, index, subindex);
  char code[16];
  std::snprintf(code, sizeof code, "0x%08X", o.abort);
  if (o.ok()) return std::string(head) + "done";
  if (o.bus_blocked) {
    return std::string(head) + "the bus took no frame for " + std::to_string(timeout_us_ / 1000) +
           " ms (no other node acknowledges, or the controller is bus-off)";
  }
  if (o.abort == sdo::kAbortTimeout && !o.by_server) {
    return std::string(head) + "no answer within " + std::to_string(timeout_us_ / 1000) +
           " ms (is the node on the bus?)";
  }
  return std::string(head) + (o.by_server ? "the node aborted the transfer: " : "aborted here: ") +
         code + " (" + sdo::abort_meaning(o.abort) + ")";
}

}  // namespace delta::can
