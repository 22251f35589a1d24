// CiA 301 SDO client: expedited, segmented and block transfers.
#include "delta/can/sdo.hpp"
#include "sdo_bytes.hpp"

namespace delta::can::sdo {

namespace {

using detail::copy_bytes;
using detail::kSegmentBytes;
using detail::smaller;

constexpr bool multiplexer_is(const Payload& r, std::uint16_t index, std::uint8_t subindex) {
  return get_index(r) == index && r[3] == subindex;
}

}  // namespace

Client::Client(std::uint32_t timeout_us, std::uint8_t block_size)
    : timeout_us_(timeout_us), block_size_(usable_block_size(block_size)) {}

bool Client::pending(Payload& out) const {
  return request_.peek(out);
}

void Client::request(const Payload& p) {
  request_.put(p);
  deadline_armed_ = false;  // armed when it is on the bus
}

void Client::arm(TimeUs now_us) {
  deadline_us_ = now_us + timeout_us_;
  deadline_armed_ = true;
}

void Client::start(std::uint16_t index, std::uint8_t subindex, TimeUs now_us) {
  index_ = index;
  subindex_ = subindex;
  status_ = ClientStatus::kBusy;
  abort_code_ = kNoAbort;
  aborted_by_server_ = false;
  offset_ = 0;
  block_offset_ = 0;
  toggle_ = false;
  crc_value_ = 0;
  next_seq_ = 1;
  ack_seq_ = 0;
  last_seq_ = 0;
  last_segment_seen_ = false;
  size_known_ = false;
  size_ = 0;
  now_us_ = now_us;
}

void Client::fail(AbortCode code, bool by_server, bool tell_server) {
  status_ = ClientStatus::kAborted;
  abort_code_ = code;
  aborted_by_server_ = by_server;
  state_ = State::kIdle;
  deadline_armed_ = false;
  if (tell_server) {
    request(abort_transfer(index_, subindex_, code));
  } else {
    request_.drop();
  }
}

void Client::done() {
  status_ = ClientStatus::kDone;
  state_ = State::kIdle;
  deadline_armed_ = false;
}

void Client::cancel(AbortCode code) {
  if (status_ == ClientStatus::kBusy) fail(code, false, true);
}

void Client::tick(TimeUs now_us) {
  now_us_ = now_us;
  if (status_ == ClientStatus::kBusy && deadline_armed_ && now_us >= deadline_us_) {
    fail(kAbortTimeout, false, true);
  }
}

void Client::download(std::uint16_t index, std::uint8_t subindex,
                      std::span<const std::uint8_t> data, Transfer transfer, TimeUs now_us) {
  start(index, subindex, now_us);
  data_ = data;
  const auto size = static_cast<std::uint32_t>(data.size());
  Payload p{};
  if (transfer == Transfer::kBlock) {
    put_header(p, 0xC6, index, subindex);  // ccs 6, client CRC support, size indicated
    put_u32(p, size);
    state_ = State::kBlockDownloadInitiate;
  } else if (transfer == Transfer::kAuto && size >= 1 && size <= 4) {
    put_header(p, static_cast<std::uint8_t>(0x23 | ((4 - size) << 2)), index, subindex);
    copy_bytes(data.data(), data.size(), p.data() + 4);
    expedited_ = true;
    state_ = State::kDownloadInitiate;
  } else {
    put_header(p, 0x21, index, subindex);  // segmented, size indicated
    put_u32(p, size);
    expedited_ = false;
    state_ = State::kDownloadInitiate;
  }
  request(p);
}

void Client::upload(std::uint16_t index, std::uint8_t subindex, std::span<std::uint8_t> buffer,
                    Transfer transfer, TimeUs now_us) {
  start(index, subindex, now_us);
  buffer_ = buffer;
  Payload p{};
  if (transfer == Transfer::kBlock) {
    put_header(p, 0xA4, index, subindex);  // ccs 5, client CRC support, cs 0
    p[4] = block_size_;
    p[5] = 0;  // no protocol switch
    state_ = State::kBlockUploadInitiate;
  } else {
    put_header(p, kUploadRequest, index, subindex);
    state_ = State::kUploadInitiate;
  }
  request(p);
}

void Client::sent(TimeUs now_us) {
  now_us_ = now_us;
  if (!request_.take()) return;
  if (state_ == State::kIdle) return;  // an abort, or the last confirmation
  if (state_ != State::kBlockDownloadSending) return arm(now_us);
  const std::uint32_t at = block_offset_ + (next_seq_ - 1u) * kSegmentBytes;
  const bool last = at + segment_bytes(at) == data_.size();
  if (last) last_seq_ = next_seq_;
  if (last || next_seq_ == block_) {
    ++next_seq_;
    state_ = State::kBlockDownloadAck;
    return arm(now_us);
  }
  ++next_seq_;
  request(block_download_segment());
}

TimeUs Client::deadline_us() const {
  return status_ == ClientStatus::kBusy && deadline_armed_ ? deadline_us_ : 0;
}

std::uint32_t Client::segment_bytes(std::uint32_t at) const {
  return smaller(kSegmentBytes, static_cast<std::uint32_t>(data_.size()) - at);
}

Payload Client::download_segment() const {
  const std::uint32_t bytes = segment_bytes(offset_);
  const bool last = offset_ + bytes == data_.size();
  Payload p{};
  p[0] = static_cast<std::uint8_t>((toggle_ ? 0x10 : 0) | ((kSegmentBytes - bytes) << 1) |
                                   (last ? 1 : 0));
  copy_bytes(data_.data() + offset_, bytes, p.data() + 1);
  return p;
}

Payload Client::block_download_segment() const {
  const std::uint32_t at = block_offset_ + (next_seq_ - 1u) * kSegmentBytes;
  const std::uint32_t bytes = segment_bytes(at);
  const bool last = at + bytes == data_.size();
  Payload p{};
  p[0] = static_cast<std::uint8_t>((last ? 0x80 : 0) | next_seq_);
  copy_bytes(data_.data() + at, bytes, p.data() + 1);
  return p;
}

void Client::on_frame(const Payload& response, TimeUs now_us) {
  now_us_ = now_us;
  if (status_ != ClientStatus::kBusy || state_ == State::kIdle) return;
  // An answer about another object is a late answer to an earlier request
  // (one that timed out and was repeated, or aborted): not this transfer's.
  const bool initiating = state_ == State::kDownloadInitiate || state_ == State::kUploadInitiate ||
                          state_ == State::kBlockDownloadInitiate ||
                          state_ == State::kBlockUploadInitiate;
  const bool other_object = !multiplexer_is(response, index_, subindex_);
  if (response[0] == kAbort) {
    const bool unnamed = multiplexer_is(response, 0, 0);
    if (other_object && !unnamed) return;
    return fail(get_u32(response), true, false);
  }
  if (initiating && other_object) return;
  switch (state_) {
    case State::kDownloadInitiate:
    case State::kDownloadSegment:
      return on_download_response(response);
    case State::kUploadInitiate:
    case State::kUploadSegment:
      return on_upload_response(response);
    case State::kBlockDownloadInitiate:
    case State::kBlockDownloadSending:
    case State::kBlockDownloadAck:
    case State::kBlockDownloadEnd:
      return on_block_download_response(response);
    case State::kBlockUploadInitiate:
    case State::kBlockUploadReceiving:
    case State::kBlockUploadEnd:
      return on_block_upload_response(response);
    case State::kIdle:
      return;
  }
}

void Client::on_download_response(const Payload& r) {
  if (state_ == State::kDownloadInitiate) {
    if (r[0] != kDownloadAck || !multiplexer_is(r, index_, subindex_)) {
      return fail(kAbortCommand, false, true);
    }
    if (expedited_) return done();
    state_ = State::kDownloadSegment;
    return request(download_segment());
  }
  if ((r[0] & 0xEF) != 0x20) return fail(kAbortCommand, false, true);
  if (((r[0] & 0x10) != 0) != toggle_) return fail(kAbortToggleBit, false, true);
  const std::uint32_t bytes = segment_bytes(offset_);
  offset_ += bytes;
  toggle_ = !toggle_;
  if (offset_ == data_.size()) return done();
  request(download_segment());
}

bool Client::store(std::span<const std::uint8_t> bytes) {
  if (offset_ + bytes.size() > buffer_.size()) return false;
  copy_bytes(bytes.data(), bytes.size(), buffer_.data() + offset_);
  offset_ += static_cast<std::uint32_t>(bytes.size());
  return true;
}

void Client::on_upload_response(const Payload& r) {
  if (state_ == State::kUploadInitiate) {
    if ((r[0] & 0xE0) != 0x40 || !multiplexer_is(r, index_, subindex_)) {
      return fail(kAbortCommand, false, true);
    }
    const bool expedited = (r[0] & 2) != 0;
    const bool size_indicated = (r[0] & 1) != 0;
    if (expedited) {
      const std::uint32_t bytes = size_indicated ? 4 - ((r[0] >> 2) & 3u) : 4;
      if (!store(std::span<const std::uint8_t>(r).subspan(4, bytes))) {
        return fail(kAbortOutOfMemory, false, false);  // the server is done already
      }
      return done();
    }
    size_known_ = size_indicated;
    size_ = size_indicated ? get_u32(r) : 0;
    if (size_known_ && size_ > buffer_.size()) return fail(kAbortOutOfMemory, false, true);
    state_ = State::kUploadSegment;
    return request(upload_segment_request());
  }
  if ((r[0] & 0xE0) != 0x00) return fail(kAbortCommand, false, true);
  if (((r[0] & 0x10) != 0) != toggle_) return fail(kAbortToggleBit, false, true);
  const std::uint32_t bytes = kSegmentBytes - ((r[0] >> 1) & 7u);
  const bool last = (r[0] & 1) != 0;
  if (!store(std::span<const std::uint8_t>(r).subspan(1, bytes))) {
    return fail(kAbortOutOfMemory, false, !last);
  }
  toggle_ = !toggle_;
  if (size_known_ && offset_ > size_) return fail(kAbortLengthTooHigh, false, !last);
  if (!last) return request(upload_segment_request());
  if (size_known_ && offset_ != size_) return fail(kAbortLengthMismatch, false, false);
  done();
}

Payload Client::upload_segment_request() const {
  Payload p{};
  p[0] = static_cast<std::uint8_t>(0x60 | (toggle_ ? 0x10 : 0));
  return p;
}

void Client::on_block_download_response(const Payload& r) {
  if (state_ == State::kBlockDownloadInitiate) {
    if ((r[0] & 0xE3) != 0xA0 || !multiplexer_is(r, index_, subindex_)) {
      return fail(kAbortCommand, false, true);
    }
    crc_ = (r[0] & 0x04) != 0;
    block_ = r[4];
    if (block_ == 0 || block_ > kMaxBlockSize) return fail(kAbortBlockSize, false, true);
    state_ = State::kBlockDownloadSending;
    return request(block_download_segment());
  }
  if (state_ == State::kBlockDownloadAck && r[0] == kBlockAcknowledge)
    return block_acknowledged(r[1], r[2]);
  if (state_ == State::kBlockDownloadEnd && r[0] == 0xA1) return done();
  fail(kAbortCommand, false, true);
}

void Client::block_acknowledged(std::uint8_t ack_seq, std::uint8_t next_block) {
  if (ack_seq >= next_seq_) return fail(kAbortSequenceNumber, false, true);
  if (next_block == 0 || next_block > kMaxBlockSize) return fail(kAbortBlockSize, false, true);
  const auto size = static_cast<std::uint32_t>(data_.size());
  if (last_seq_ != 0 && ack_seq >= last_seq_) {
    const std::uint32_t tail = size % kSegmentBytes;
    const std::uint32_t unused = size == 0 ? kSegmentBytes : (tail == 0 ? 0 : kSegmentBytes - tail);
    const std::uint16_t crc = crc_ ? crc16(0, data_) : 0;
    Payload p{};
    p[0] = static_cast<std::uint8_t>(0xC1 | (unused << 2));
    p[1] = static_cast<std::uint8_t>(crc & 0xFF);
    p[2] = static_cast<std::uint8_t>(crc >> 8);
    offset_ = size;
    state_ = State::kBlockDownloadEnd;
    return request(p);
  }
  block_offset_ = smaller(size, block_offset_ + ack_seq * kSegmentBytes);
  offset_ = block_offset_;
  block_ = next_block;
  next_seq_ = 1;
  last_seq_ = 0;
  state_ = State::kBlockDownloadSending;
  request(block_download_segment());
}

void Client::on_block_upload_response(const Payload& r) {
  if (state_ == State::kBlockUploadInitiate) {
    if ((r[0] & 0xE1) != 0xC0 || !multiplexer_is(r, index_, subindex_)) {
      return fail(kAbortCommand, false, true);
    }
    crc_ = (r[0] & 0x04) != 0;
    size_known_ = (r[0] & 0x02) != 0;
    size_ = size_known_ ? get_u32(r) : 0;
    if (size_known_ && size_ > buffer_.size()) return fail(kAbortOutOfMemory, false, true);
    block_ = block_size_;
    state_ = State::kBlockUploadReceiving;
    Payload p{};
    p[0] = 0xA3;  // start upload
    return request(p);
  }
  if (state_ == State::kBlockUploadReceiving) return block_upload_segment(r);
  if ((r[0] & 0xE3) != 0xC1) return fail(kAbortCommand, false, true);
  block_upload_end(r);
}

void Client::block_upload_segment(const Payload& r) {
  const auto seq = static_cast<std::uint8_t>(r[0] & 0x7F);
  const bool last = (r[0] & 0x80) != 0;
  if (seq == 0 || seq > block_) return fail(kAbortSequenceNumber, false, true);
  if (seq == ack_seq_ + 1 && !last_segment_seen_) {
    // A last segment's padding is not data: keep what fits, count at the end.
    const std::span<const std::uint8_t> bytes = std::span<const std::uint8_t>(r).subspan(1);
    last_segment_at_ = offset_;
    if (last) {
      const std::size_t room = buffer_.size() - offset_;
      copy_bytes(bytes.data(), room < kSegmentBytes ? room : kSegmentBytes,
                 buffer_.data() + offset_);
    } else if (!store(bytes)) {
      return fail(kAbortOutOfMemory, false, true);
    }
    ack_seq_ = seq;
    last_segment_seen_ = last;
  }
  if (last || seq == block_) {
    const Payload p = block_acknowledge(ack_seq_, block_size_);
    block_ = block_size_;
    if (last_segment_seen_) {
      state_ = State::kBlockUploadEnd;
    } else {
      ack_seq_ = 0;
    }
    return request(p);
  }
  arm(now_us_);
}

void Client::block_upload_end(const Payload& r) {
  const std::uint32_t bytes = kSegmentBytes - ((r[0] >> 2) & 7u);
  const std::uint32_t total = last_segment_at_ + bytes;
  if (total > buffer_.size()) return fail(kAbortOutOfMemory, false, true);
  if (size_known_ && total != size_) return fail(kAbortLengthMismatch, false, true);
  offset_ = total;
  const auto crc = static_cast<std::uint16_t>(r[1] | (r[2] << 8));
  if (crc_ && crc16(0, buffer_.first(total)) != crc) return fail(kAbortCrc, false, true);
  Payload p{};
  p[0] = 0xA1;  // end of the block upload
  request(p);
  done();
}

}  // namespace delta::can::sdo
