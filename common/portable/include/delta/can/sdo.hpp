// CiA 301 SDO, client and server, written once for every node of the
// product: the controller's master (client), the emulated drives (server),
// the controller's own node (server) and host_id (client).
//
// Expedited (with and without the size indicated), segmented and block
// transfers (with CRC) both ways, every abort code CiA 301 gives, and
// timeouts. No heap, no exceptions, no floating point: the firmware core
// and a microcontroller port use it as it is.
//
// The engines do no I/O. A frame in goes to on_frame(); the frames to send
// are pulled with pending() and confirmed with sent() once the bus took
// them, so a full transmit queue (ENOBUFS, EAGAIN) paces the transfer
// instead of breaking it. tick() runs the timeouts. docs/protocol.md
// describes the protocol as the product uses it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace delta::can::sdo {

using Payload = std::array<std::uint8_t, 8>;
using AbortCode = std::uint32_t;
inline constexpr AbortCode kNoAbort = 0;

// The abort codes of CiA 301 (table "SDO abort codes").
inline constexpr AbortCode kAbortToggleBit = 0x05030000;
inline constexpr AbortCode kAbortTimeout = 0x05040000;
inline constexpr AbortCode kAbortCommand = 0x05040001;
inline constexpr AbortCode kAbortBlockSize = 0x05040002;
inline constexpr AbortCode kAbortSequenceNumber = 0x05040003;
inline constexpr AbortCode kAbortCrc = 0x05040004;
inline constexpr AbortCode kAbortOutOfMemory = 0x05040005;
inline constexpr AbortCode kAbortUnsupportedAccess = 0x06010000;
inline constexpr AbortCode kAbortWriteOnly = 0x06010001;
inline constexpr AbortCode kAbortReadOnly = 0x06010002;
inline constexpr AbortCode kAbortObjectDoesNotExist = 0x06020000;
inline constexpr AbortCode kAbortNotMappable = 0x06040041;
inline constexpr AbortCode kAbortPdoLength = 0x06040042;
inline constexpr AbortCode kAbortParameterIncompatible = 0x06040043;
inline constexpr AbortCode kAbortInternalIncompatible = 0x06040047;
inline constexpr AbortCode kAbortHardware = 0x06060000;
inline constexpr AbortCode kAbortLengthMismatch = 0x06070010;
inline constexpr AbortCode kAbortLengthTooHigh = 0x06070012;
inline constexpr AbortCode kAbortLengthTooLow = 0x06070013;
inline constexpr AbortCode kAbortSubindexDoesNotExist = 0x06090011;
inline constexpr AbortCode kAbortValueRange = 0x06090030;
inline constexpr AbortCode kAbortValueTooHigh = 0x06090031;
inline constexpr AbortCode kAbortValueTooLow = 0x06090032;
inline constexpr AbortCode kAbortMaxBelowMin = 0x06090036;
inline constexpr AbortCode kAbortNoResource = 0x060A0023;
inline constexpr AbortCode kAbortGeneral = 0x08000000;
inline constexpr AbortCode kAbortCannotStore = 0x08000020;
inline constexpr AbortCode kAbortLocalControl = 0x08000021;
inline constexpr AbortCode kAbortDeviceState = 0x08000022;
inline constexpr AbortCode kAbortNoDictionary = 0x08000023;
inline constexpr AbortCode kAbortNoData = 0x08000024;

// CiA 301's text for an abort code; "unknown abort code" for others.
const char* abort_meaning(AbortCode code);

// The block transfers' CRC: CRC-16-CCITT, polynomial 0x1021, initial value
// 0, no reflection (CiA 301 7.2.4.3.16). crc16("123456789") == 0x31C3.
std::uint16_t crc16(std::uint16_t crc, std::span<const std::uint8_t> data);

// ---- Frame layout helpers (the multiplexer is index LE, sub-index) ----

inline constexpr std::uint8_t kUploadRequest = 0x40;
inline constexpr std::uint8_t kDownloadAck = 0x60;
inline constexpr std::uint8_t kAbort = 0x80;

constexpr void put_header(Payload& p, std::uint8_t command, std::uint16_t index,
                          std::uint8_t subindex) {
  p[0] = command;
  p[1] = static_cast<std::uint8_t>(index & 0xFF);
  p[2] = static_cast<std::uint8_t>(index >> 8);
  p[3] = subindex;
}

constexpr void put_u32(Payload& p, std::uint32_t v) {
  for (unsigned i = 0; i < 4; ++i) p[4 + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

constexpr std::uint32_t get_u32(const Payload& p) {
  std::uint32_t v = 0;
  for (unsigned i = 0; i < 4; ++i) v |= std::uint32_t{p[4 + i]} << (8 * i);
  return v;
}

constexpr std::uint16_t get_index(const Payload& p) {
  return static_cast<std::uint16_t>(p[1] | (p[2] << 8));
}

// Expedited download (write) of 1, 2 or 4 bytes: 0x2F, 0x2B, 0x23.
constexpr Payload download_request(std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                   std::uint8_t size_bytes) {
  Payload p{};
  const auto n = static_cast<std::uint8_t>(size_bytes == 1 ? 3 : (size_bytes == 2 ? 2 : 0));
  put_header(p, static_cast<std::uint8_t>(0x23 | (n << 2)), index, subindex);
  put_u32(p, value);
  return p;
}

constexpr Payload upload_request(std::uint16_t index, std::uint8_t subindex) {
  Payload p{};
  put_header(p, kUploadRequest, index, subindex);
  return p;
}

constexpr Payload abort_transfer(std::uint16_t index, std::uint8_t subindex, AbortCode code) {
  Payload p{};
  put_header(p, kAbort, index, subindex);
  put_u32(p, code);
  return p;
}

constexpr Payload download_response(std::uint16_t index, std::uint8_t subindex) {
  Payload p{};
  put_header(p, kDownloadAck, index, subindex);
  return p;
}

// A block's acknowledgement (0xA2), by the side that receives the block:
// the last segment taken in order, and the next block's size.
inline constexpr std::uint8_t kBlockAcknowledge = 0xA2;
constexpr Payload block_acknowledge(std::uint8_t last_in_order, std::uint8_t next_block_size) {
  Payload p{};
  p[0] = kBlockAcknowledge;
  p[1] = last_in_order;
  p[2] = next_block_size;
  return p;
}

// An expedited upload response of the object's 1, 2 or 4 bytes, size
// indicated: 0x4F, 0x4B, 0x43 (the unused bytes zero).
constexpr Payload upload_response(std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                  std::uint8_t size_bytes = 4) {
  Payload p{};
  const auto unused = static_cast<std::uint8_t>(4 - size_bytes);
  put_header(p, static_cast<std::uint8_t>(0x43 | (unused << 2)), index, subindex);
  put_u32(p, size_bytes == 4 ? value : value & ((std::uint32_t{1} << (8 * size_bytes)) - 1));
  return p;
}

// The data bytes of an expedited download request: 1 to 4 with the size
// indicated, 0 without (CiA 301 allows it; the object's size applies).
constexpr unsigned expedited_download_bytes(std::uint8_t command) {
  return (command & 0x01) != 0 ? 4u - ((command >> 2) & 3u) : 0u;
}

enum class ResponseKind : std::uint8_t { kDownloadDone, kUploadValue, kAborted, kUnexpected };

struct Response {
  ResponseKind kind{ResponseKind::kUnexpected};
  std::uint16_t index{0};
  std::uint8_t subindex{0};
  std::uint32_t value{0};  // the uploaded value, or the abort code
};

// Reads a server's answer to an expedited request.
constexpr Response parse_response(const Payload& p) {
  Response r;
  r.index = get_index(p);
  r.subindex = p[3];
  if (p[0] == kAbort) {
    r.kind = ResponseKind::kAborted;
    r.value = get_u32(p);
  } else if (p[0] == kDownloadAck) {
    r.kind = ResponseKind::kDownloadDone;
  } else if ((p[0] & 0xE3) == 0x43) {  // expedited upload, size indicated
    const unsigned unused = (p[0] >> 2) & 3;
    const std::uint32_t v = get_u32(p);
    r.kind = ResponseKind::kUploadValue;
    r.value = unused == 0 ? v : (v & ((std::uint32_t{1} << (8 * (4 - unused))) - 1));
  }
  return r;
}

// ---- The server's view of an object dictionary ----

struct ObjectInfo {
  std::uint32_t size{0};      // bytes now (a domain's or string's current length)
  std::uint32_t capacity{0};  // the most a download may write (fixed types: size)
  bool readable{false};
  bool writable{false};
  bool variable_length{false};  // domain or string: any length up to capacity
};

// What a node's object dictionary offers the SDO server. Lookups name the
// missing object (0x06020000) or sub-index (0x06090011); read() copies a
// byte range of the object's current value; write() receives a download's
// bytes in order, the final piece with `last`, and checks the value there
// (a value-range or state abort leaves the object as it was). An object that
// fits in one frame arrives in one write().
class ObjectDictionary {
 public:
  virtual AbortCode find(std::uint16_t index, std::uint8_t subindex, ObjectInfo& info) = 0;
  virtual AbortCode read(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                         std::span<std::uint8_t> out) = 0;
  virtual AbortCode write(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                          std::span<const std::uint8_t> data, bool last) = 0;
  // A download that had begun ended without its last piece.
  virtual void download_abandoned(std::uint16_t index, std::uint8_t subindex) {
    (void)index;
    (void)subindex;
  }

 protected:
  ObjectDictionary() = default;
  ObjectDictionary(const ObjectDictionary&) = default;
  ObjectDictionary& operator=(const ObjectDictionary&) = default;
  ~ObjectDictionary() = default;
};

// Microseconds on the caller's monotonic clock.
using TimeUs = std::uint64_t;
inline constexpr std::uint32_t kDefaultTimeoutUs = 500'000;
inline constexpr std::uint8_t kMaxBlockSize = 127;  // segments per block

// The block size a side uses: the one given, or CiA 301's largest where the
// one given is 0 or above it.
constexpr std::uint8_t usable_block_size(std::uint8_t given) {
  return given == 0 || given > kMaxBlockSize ? kMaxBlockSize : given;
}

// A side's next frame, waiting for the bus: put() by its state machine,
// shown by peek() and taken by take() once the bus took it.
class Outgoing {
 public:
  void put(const Payload& p) {
    payload_ = p;
    waiting_ = true;
  }
  bool peek(Payload& out) const {
    if (!waiting_) return false;
    out = payload_;
    return true;
  }
  // Whether a frame was waiting; none is after it.
  bool take() {
    const bool was = waiting_;
    waiting_ = false;
    return was;
  }
  void drop() { waiting_ = false; }
  bool waiting() const { return waiting_; }
  const Payload& payload() const { return payload_; }

 private:
  Payload payload_{};
  bool waiting_{false};
};

// ---- Server ----

class Server {
 public:
  explicit Server(ObjectDictionary& dictionary, std::uint32_t timeout_us = kDefaultTimeoutUs,
                  std::uint8_t block_size = kMaxBlockSize);

  // A request from the client (an SDO frame's 8 bytes; a shorter frame is
  // not an SDO request and gets no answer, as CiA 301 gives none).
  void on_frame(const Payload& request, TimeUs now_us);
  // A transfer that waits for the client longer than the timeout is
  // aborted with 0x05040000.
  void tick(TimeUs now_us);
  // The next frame to send, if any; sent() once the bus took it.
  bool pending(Payload& out) const;
  void sent(TimeUs now_us);
  bool idle() const { return state_ == State::kIdle && !reply_.waiting(); }

 private:
  enum class State : std::uint8_t {
    kIdle,
    kDownloadSegments,
    kUploadSegments,
    kBlockDownload,
    kBlockDownloadEnd,
    kBlockDownloadDiscard,  // the rest of a block whose download was aborted
    kBlockUploadStart,
    kBlockUploadSending,
    kBlockUploadAck,
    kBlockUploadEndAck,
  };

  void reply(const Payload& p);
  void abort(AbortCode code);
  void finish();
  void arm();
  bool downloading() const;
  void on_idle_request(const Payload& r);
  void initiate_download(const Payload& r);
  void initiate_upload();
  void download_segment(const Payload& r);
  void upload_segment(const Payload& r);
  void initiate_block_download(const Payload& r);
  void block_download_segment(const Payload& r);
  void end_block_download(const Payload& r);
  void discard_segment(const Payload& r);
  void initiate_block_upload(const Payload& r);
  void block_upload_client(const Payload& r);
  void block_acknowledged(std::uint8_t ack_seq, std::uint8_t next_block);
  void prepare_block_segment();
  AbortCode check_download_size(std::uint32_t size) const;
  AbortCode write_piece(std::span<const std::uint8_t> data, bool last);

  ObjectDictionary& dictionary_;
  std::uint32_t timeout_us_;
  std::uint8_t block_size_;
  State state_{State::kIdle};
  std::uint16_t index_{0};
  std::uint8_t subindex_{0};
  ObjectInfo info_{};
  std::uint32_t size_{0};  // the transfer's size (0 and !size_known_: unknown)
  bool size_known_{false};
  std::uint32_t offset_{0};  // bytes written to or read from the object
  bool toggle_{false};
  bool crc_{false};
  std::uint16_t crc_value_{0};
  // Block download: the last in-order segment, held until the next one or
  // the end request says how many of its bytes are data.
  std::array<std::uint8_t, 7> held_{};
  bool holding_{false};
  bool last_segment_seen_{false};
  std::uint8_t ack_seq_{0};
  std::uint8_t block_{0};         // this block's size
  std::uint8_t segment_seq_{0};   // the block segment being handled (0: none)
  std::uint8_t discard_next_{0};  // after an abort mid-block: the next to discard
  // Block upload: where this block starts, the next segment to send, the
  // sequence number of the segment that carried the last byte (0: not yet
  // sent in this block), and how far the CRC has covered.
  std::uint32_t block_offset_{0};
  std::uint8_t next_seq_{1};
  std::uint8_t last_seq_{0};
  std::uint32_t crc_offset_{0};
  Outgoing reply_;
  TimeUs deadline_us_{0};
  bool deadline_armed_{false};
  TimeUs now_us_{0};
};

// ---- Client ----

enum class Transfer : std::uint8_t {
  kAuto,       // expedited up to 4 bytes, else segmented
  kSegmented,  // segmented even for small objects (download)
  kBlock,      // block transfer with CRC
};

enum class ClientStatus : std::uint8_t { kIdle, kBusy, kDone, kAborted };

class Client {
 public:
  explicit Client(std::uint32_t timeout_us = kDefaultTimeoutUs,
                  std::uint8_t block_size = kMaxBlockSize);

  // Writes `data` (which must outlive the transfer) to index:subindex.
  void download(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data,
                Transfer transfer, TimeUs now_us);
  // Reads index:subindex into `buffer`; uploaded_size() is the length.
  // More data than the buffer holds aborts with 0x05040005.
  void upload(std::uint16_t index, std::uint8_t subindex, std::span<std::uint8_t> buffer,
              Transfer transfer, TimeUs now_us);
  // Aborts the transfer in progress with `code` (sent to the server).
  void cancel(AbortCode code);

  // A server's frame. An answer that names another object while this
  // transfer waits for its first answer is a late answer to an earlier
  // request and is ignored.
  void on_frame(const Payload& response, TimeUs now_us);
  void tick(TimeUs now_us);
  bool pending(Payload& out) const;
  void sent(TimeUs now_us);
  // When the transfer times out unless an answer comes (0: not waiting).
  TimeUs deadline_us() const;

  ClientStatus status() const { return status_; }
  AbortCode abort_code() const { return abort_code_; }
  // The abort came from the server (else the client aborted: timeout,
  // toggle, CRC, size).
  bool aborted_by_server() const { return aborted_by_server_; }
  std::uint32_t uploaded_size() const { return offset_; }
  // Bytes the server confirmed (download) or that arrived (upload) so far.
  std::uint32_t transferred() const { return offset_; }
  std::uint16_t index() const { return index_; }
  std::uint8_t subindex() const { return subindex_; }

 private:
  enum class State : std::uint8_t {
    kIdle,
    kDownloadInitiate,
    kDownloadSegment,
    kUploadInitiate,
    kUploadSegment,
    kBlockDownloadInitiate,
    kBlockDownloadSending,
    kBlockDownloadAck,
    kBlockDownloadEnd,
    kBlockUploadInitiate,
    kBlockUploadReceiving,
    kBlockUploadEnd,
  };

  void start(std::uint16_t index, std::uint8_t subindex, TimeUs now_us);
  void request(const Payload& p);
  void arm(TimeUs now_us);
  void fail(AbortCode code, bool by_server, bool tell_server);
  void done();
  std::uint32_t segment_bytes(std::uint32_t at) const;
  Payload download_segment() const;
  Payload block_download_segment() const;
  Payload upload_segment_request() const;
  void on_download_response(const Payload& r);
  void on_upload_response(const Payload& r);
  void on_block_download_response(const Payload& r);
  void block_acknowledged(std::uint8_t ack_seq, std::uint8_t next_block);
  void on_block_upload_response(const Payload& r);
  void block_upload_segment(const Payload& r);
  void block_upload_end(const Payload& r);
  bool store(std::span<const std::uint8_t> bytes);

  std::uint32_t timeout_us_;
  std::uint8_t block_size_;
  State state_{State::kIdle};
  ClientStatus status_{ClientStatus::kIdle};
  AbortCode abort_code_{kNoAbort};
  bool aborted_by_server_{false};
  std::uint16_t index_{0};
  std::uint8_t subindex_{0};
  std::span<const std::uint8_t> data_{};
  std::span<std::uint8_t> buffer_{};
  bool expedited_{false};
  std::uint32_t size_{0};  // the upload's indicated size
  bool size_known_{false};
  std::uint32_t offset_{0};  // bytes confirmed (download) or stored (upload)
  bool toggle_{false};
  bool crc_{false};
  std::uint16_t crc_value_{0};
  // Block transfers: this block's size, where it starts, the next sequence
  // number, the last acknowledged one, and the segment with the last byte.
  std::uint8_t block_{0};
  std::uint32_t block_offset_{0};
  std::uint8_t next_seq_{1};
  std::uint8_t ack_seq_{0};
  std::uint8_t last_seq_{0};
  bool last_segment_seen_{false};
  std::uint32_t last_segment_at_{0};
  Outgoing request_;
  TimeUs deadline_us_{0};
  bool deadline_armed_{false};
  TimeUs now_us_{0};
};

}  // namespace delta::can::sdo
