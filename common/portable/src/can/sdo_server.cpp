// CiA 301 SDO server: expedited, segmented and block transfers over an
// ObjectDictionary.
#include "delta/can/sdo.hpp"
#include "sdo_bytes.hpp"

namespace delta::can::sdo {

namespace {

using detail::copy_bytes;
using detail::kSegmentBytes;
using detail::smaller;

constexpr std::uint8_t client_command(const Payload& r) {
  return static_cast<std::uint8_t>(r[0] >> 5);
}

constexpr std::uint16_t get_u16(const Payload& p, unsigned at) {
  return static_cast<std::uint16_t>(p[at] | (p[at + 1] << 8));
}

}  // namespace

Server::Server(ObjectDictionary& dictionary, std::uint32_t timeout_us, std::uint8_t block_size)
    : dictionary_(dictionary),
      timeout_us_(timeout_us),
      block_size_(usable_block_size(block_size)) {}

bool Server::pending(Payload& out) const {
  return reply_.peek(out);
}

void Server::reply(const Payload& p) {
  reply_.put(p);
}

void Server::arm() {
  deadline_us_ = now_us_ + timeout_us_;
  deadline_armed_ = true;
}

bool Server::downloading() const {
  return state_ == State::kDownloadSegments || state_ == State::kBlockDownload ||
         state_ == State::kBlockDownloadEnd;
}

void Server::finish() {
  state_ = State::kIdle;
  deadline_armed_ = false;
}

void Server::abort(AbortCode code) {
  if (downloading()) dictionary_.download_abandoned(index_, subindex_);
  reply(abort_transfer(index_, subindex_, code));
  finish();
  // Aborted on a block segment that did not end the block: the client sent
  // the block's remaining segments before the abort reached it. They are
  // the dead transfer's, not requests (their bytes could read as a write
  // to some object): discard them, in sequence, until the block's end.
  if (segment_seq_ != 0 && segment_seq_ < block_) {
    state_ = State::kBlockDownloadDiscard;
    discard_next_ = static_cast<std::uint8_t>(segment_seq_ + 1);
    arm();
  }
}

// After an abort mid-block: the block's next segment is discarded; anything
// else is a request again.
void Server::discard_segment(const Payload& r) {
  const auto seq = static_cast<std::uint8_t>(r[0] & 0x7F);
  if (seq != discard_next_) {
    finish();
    return on_idle_request(r);
  }
  if ((r[0] & 0x80) != 0 || seq == block_) return finish();
  ++discard_next_;
  arm();
}

void Server::tick(TimeUs now_us) {
  now_us_ = now_us;
  if (state_ == State::kBlockDownloadDiscard && deadline_armed_ && now_us >= deadline_us_) {
    return finish();  // the rest of the block never came: nothing to answer
  }
  if (state_ != State::kIdle && deadline_armed_ && now_us >= deadline_us_) abort(kAbortTimeout);
}

void Server::on_frame(const Payload& request, TimeUs now_us) {
  now_us_ = now_us;
  if (request[0] == kAbort) {  // the client gave up: no answer
    if (downloading()) dictionary_.download_abandoned(index_, subindex_);
    finish();
    return;
  }
  const std::uint8_t ccs = client_command(request);
  switch (state_) {
    case State::kIdle:
      return on_idle_request(request);
    case State::kDownloadSegments:
      return ccs == 0 ? download_segment(request) : abort(kAbortCommand);
    case State::kUploadSegments:
      return ccs == 3 ? upload_segment(request) : abort(kAbortCommand);
    case State::kBlockDownload:
      return block_download_segment(request);  // every frame is a segment here
    case State::kBlockDownloadDiscard:
      return discard_segment(request);
    case State::kBlockDownloadEnd:
      return ccs == 6 && (request[0] & 1) == 1 ? end_block_download(request) : abort(kAbortCommand);
    case State::kBlockUploadStart:
    case State::kBlockUploadSending:
    case State::kBlockUploadAck:
    case State::kBlockUploadEndAck:
      return ccs == 5 ? block_upload_client(request) : abort(kAbortCommand);
  }
}

void Server::on_idle_request(const Payload& r) {
  const std::uint8_t ccs = client_command(r);
  const bool initiate =
      ccs == 1 || ccs == 2 || (ccs == 5 && (r[0] & 3) == 0) || (ccs == 6 && (r[0] & 1) == 0);
  index_ = initiate ? get_index(r) : 0;
  subindex_ = initiate ? r[3] : 0;
  if (!initiate) return abort(kAbortCommand);
  const AbortCode found = dictionary_.find(index_, subindex_, info_);
  if (found != kNoAbort) return abort(found);
  const bool download = ccs == 1 || ccs == 6;
  if (download && !info_.writable) return abort(kAbortReadOnly);
  if (!download && !info_.readable) return abort(kAbortWriteOnly);
  offset_ = 0;
  toggle_ = false;
  crc_value_ = 0;
  if (ccs == 1) return initiate_download(r);
  if (ccs == 2) return initiate_upload();
  if (ccs == 6) return initiate_block_download(r);
  initiate_block_upload(r);
}

AbortCode Server::check_download_size(std::uint32_t size) const {
  if (info_.variable_length) return size > info_.capacity ? kAbortLengthTooHigh : kNoAbort;
  if (size > info_.size) return kAbortLengthTooHigh;
  if (size < info_.size) return kAbortLengthTooLow;
  return kNoAbort;
}

AbortCode Server::write_piece(std::span<const std::uint8_t> data, bool last) {
  const AbortCode code = dictionary_.write(index_, subindex_, offset_, data, last);
  if (code == kNoAbort) offset_ += static_cast<std::uint32_t>(data.size());
  return code;
}

void Server::initiate_download(const Payload& r) {
  const bool expedited = (r[0] & 2) != 0;
  const bool size_indicated = (r[0] & 1) != 0;
  if (!expedited) {
    size_known_ = size_indicated;
    size_ = size_indicated ? get_u32(r) : 0;
    if (size_known_) {
      if (const AbortCode c = check_download_size(size_); c != kNoAbort) return abort(c);
    }
    state_ = State::kDownloadSegments;
    reply(download_response(index_, subindex_));
    return arm();
  }
  // Expedited: the size indicated, or (not indicated) the object's own.
  std::uint32_t bytes = 4;
  if (size_indicated) {
    bytes = 4 - ((r[0] >> 2) & 3u);
  } else if (!info_.variable_length) {
    if (info_.size > 4) return abort(kAbortLengthTooLow);
    bytes = info_.size;
  }
  if (const AbortCode c = check_download_size(bytes); c != kNoAbort) return abort(c);
  state_ = State::kDownloadSegments;  // so that a refused write is abandoned
  const AbortCode written = write_piece(std::span<const std::uint8_t>(r).subspan(4, bytes), true);
  if (written != kNoAbort) return abort(written);
  reply(download_response(index_, subindex_));
  finish();
}

void Server::download_segment(const Payload& r) {
  const bool toggle = (r[0] & 0x10) != 0;
  if (toggle != toggle_) return abort(kAbortToggleBit);
  const std::uint32_t bytes = kSegmentBytes - ((r[0] >> 1) & 7u);
  const bool last = (r[0] & 1) != 0;
  const std::uint32_t total = offset_ + bytes;
  const std::uint32_t limit = size_known_ ? size_ : info_.capacity;
  if (total > limit) return abort(kAbortLengthTooHigh);
  if (last && size_known_ && total != size_) return abort(kAbortLengthTooLow);
  if (last && !size_known_ && !info_.variable_length && total != info_.size) {
    return abort(kAbortLengthTooLow);
  }
  const AbortCode written = write_piece(std::span<const std::uint8_t>(r).subspan(1, bytes), last);
  if (written != kNoAbort) return abort(written);
  Payload p{};
  p[0] = static_cast<std::uint8_t>(0x20 | (toggle ? 0x10 : 0));
  reply(p);
  toggle_ = !toggle_;
  if (last) return finish();
  arm();
}

void Server::initiate_upload() {
  size_ = info_.size;
  if (size_ >= 1 && size_ <= 4) {
    Payload p{};
    put_header(p, static_cast<std::uint8_t>(0x43 | ((4 - size_) << 2)), index_, subindex_);
    const AbortCode read =
        dictionary_.read(index_, subindex_, 0, std::span<std::uint8_t>(p).subspan(4, size_));
    if (read != kNoAbort) return abort(read);
    return reply(p);
  }
  Payload p{};
  put_header(p, 0x41, index_, subindex_);
  put_u32(p, size_);
  state_ = State::kUploadSegments;
  reply(p);
  arm();
}

void Server::upload_segment(const Payload& r) {
  const bool toggle = (r[0] & 0x10) != 0;
  if (toggle != toggle_) return abort(kAbortToggleBit);
  const std::uint32_t bytes = smaller(kSegmentBytes, size_ - offset_);
  Payload p{};
  const AbortCode read =
      dictionary_.read(index_, subindex_, offset_, std::span<std::uint8_t>(p).subspan(1, bytes));
  if (read != kNoAbort) return abort(read);
  const bool last = offset_ + bytes == size_;
  p[0] = static_cast<std::uint8_t>((toggle ? 0x10 : 0) | ((kSegmentBytes - bytes) << 1) |
                                   (last ? 1 : 0));
  reply(p);
  offset_ += bytes;
  toggle_ = !toggle_;
  if (last) return finish();
  arm();
}

void Server::initiate_block_download(const Payload& r) {
  crc_ = (r[0] & 0x04) != 0;
  size_known_ = (r[0] & 0x02) != 0;
  size_ = size_known_ ? get_u32(r) : 0;
  if (size_known_) {
    if (const AbortCode c = check_download_size(size_); c != kNoAbort) return abort(c);
  }
  holding_ = false;
  last_segment_seen_ = false;
  ack_seq_ = 0;
  block_ = block_size_;
  Payload p{};
  put_header(p, 0xA4, index_, subindex_);  // scs 5, server CRC support, ss 0
  p[4] = block_;
  state_ = State::kBlockDownload;
  reply(p);
  arm();
}

void Server::block_download_segment(const Payload& r) {
  const auto seq = static_cast<std::uint8_t>(r[0] & 0x7F);
  const bool last = (r[0] & 0x80) != 0;
  // While this segment is handled, an abort discards the block's rest.
  segment_seq_ = last ? block_ : seq;
  struct Clear {
    std::uint8_t& seq;
    ~Clear() { seq = 0; }
  } clear{segment_seq_};
  if (seq == 0 || seq > block_) return abort(kAbortSequenceNumber);
  if (seq == ack_seq_ + 1 && !last_segment_seen_) {
    if (holding_) {
      const std::uint32_t limit = size_known_ ? size_ : info_.capacity;
      if (offset_ + kSegmentBytes > limit) return abort(kAbortLengthTooHigh);
      crc_value_ = crc16(crc_value_, held_);
      if (const AbortCode c = write_piece(held_, false); c != kNoAbort) return abort(c);
    }
    copy_bytes(r.data() + 1, held_.size(), held_.data());
    holding_ = true;
    ack_seq_ = seq;
    last_segment_seen_ = last;
  }
  // Segments out of order are dropped; the acknowledgement asks for them
  // again from ack_seq_ + 1.
  if (last || seq == block_) {
    reply(block_acknowledge(ack_seq_, block_size_));
    block_ = block_size_;
    if (last_segment_seen_) {
      state_ = State::kBlockDownloadEnd;
    } else {
      ack_seq_ = 0;
    }
  }
  arm();
}

void Server::end_block_download(const Payload& r) {
  const std::uint32_t bytes = kSegmentBytes - ((r[0] >> 2) & 7u);
  const std::uint32_t total = offset_ + bytes;
  if (size_known_ && total != size_) {
    return abort(total > size_ ? kAbortLengthTooHigh : kAbortLengthTooLow);
  }
  if (!info_.variable_length && total != info_.size) {
    return abort(total > info_.size ? kAbortLengthTooHigh : kAbortLengthTooLow);
  }
  if (total > info_.capacity) return abort(kAbortLengthTooHigh);
  const std::span<const std::uint8_t> piece = std::span<const std::uint8_t>(held_).first(bytes);
  if (crc_ && crc16(crc_value_, piece) != get_u16(r, 1)) return abort(kAbortCrc);
  if (const AbortCode c = write_piece(piece, true); c != kNoAbort) return abort(c);
  Payload p{};
  p[0] = 0xA1;
  reply(p);
  finish();
}

void Server::initiate_block_upload(const Payload& r) {
  // The protocol switch threshold (byte 5) is not used: CiA 301 lets the
  // server stay with the block protocol.
  crc_ = (r[0] & 0x04) != 0;
  block_ = r[4];
  if (block_ == 0 || block_ > kMaxBlockSize) return abort(kAbortBlockSize);
  size_ = info_.size;
  Payload p{};
  put_header(p, 0xC6, index_, subindex_);  // scs 6, server CRC support, size indicated
  put_u32(p, size_);
  state_ = State::kBlockUploadStart;
  reply(p);
  arm();
}

void Server::block_upload_client(const Payload& r) {
  const unsigned cs = r[0] & 3u;
  if (state_ == State::kBlockUploadStart && cs == 3) {
    block_offset_ = 0;
    crc_offset_ = 0;
    next_seq_ = 1;
    last_seq_ = 0;
    state_ = State::kBlockUploadSending;
    deadline_armed_ = false;
    return prepare_block_segment();
  }
  if (state_ == State::kBlockUploadAck && cs == 2) return block_acknowledged(r[1], r[2]);
  if (state_ == State::kBlockUploadEndAck && cs == 1) return finish();
  abort(kAbortCommand);
}

void Server::block_acknowledged(std::uint8_t ack_seq, std::uint8_t next_block) {
  if (ack_seq >= next_seq_) return abort(kAbortSequenceNumber);
  if (next_block == 0 || next_block > kMaxBlockSize) return abort(kAbortBlockSize);
  if (last_seq_ != 0 && ack_seq >= last_seq_) {
    const std::uint32_t tail = size_ % kSegmentBytes;
    const std::uint32_t unused =
        size_ == 0 ? kSegmentBytes : (tail == 0 ? 0 : kSegmentBytes - tail);
    Payload p{};
    p[0] = static_cast<std::uint8_t>(0xC1 | (unused << 2));
    p[1] = static_cast<std::uint8_t>(crc_value_ & 0xFF);
    p[2] = static_cast<std::uint8_t>(crc_value_ >> 8);
    state_ = State::kBlockUploadEndAck;
    reply(p);
    return arm();
  }
  block_offset_ = smaller(size_, block_offset_ + ack_seq * kSegmentBytes);
  block_ = next_block;
  next_seq_ = 1;
  last_seq_ = 0;
  state_ = State::kBlockUploadSending;
  deadline_armed_ = false;
  prepare_block_segment();
}

void Server::prepare_block_segment() {
  const std::uint32_t at = block_offset_ + (next_seq_ - 1u) * kSegmentBytes;
  const std::uint32_t bytes = smaller(kSegmentBytes, size_ - at);
  const bool last = at + bytes == size_;
  Payload p{};
  const AbortCode read =
      dictionary_.read(index_, subindex_, at, std::span<std::uint8_t>(p).subspan(1, bytes));
  if (read != kNoAbort) return abort(read);
  p[0] = static_cast<std::uint8_t>((last ? 0x80 : 0) | next_seq_);
  reply(p);
}

void Server::sent(TimeUs now_us) {
  now_us_ = now_us;
  if (!reply_.take()) return;
  if (state_ != State::kBlockUploadSending) return;
  // A block segment went out: the CRC covers each byte once, however often
  // a segment is repeated.
  const std::uint32_t at = block_offset_ + (next_seq_ - 1u) * kSegmentBytes;
  const std::uint32_t bytes = smaller(kSegmentBytes, size_ - at);
  if (at == crc_offset_) {
    crc_value_ =
        crc16(crc_value_, std::span<const std::uint8_t>(reply_.payload()).subspan(1, bytes));
    crc_offset_ += bytes;
  }
  const bool last = at + bytes == size_;
  if (last) last_seq_ = next_seq_;
  if (last || next_seq_ == block_) {
    ++next_seq_;
    state_ = State::kBlockUploadAck;
    return arm();
  }
  ++next_seq_;
  prepare_block_segment();
}

}  // namespace delta::can::sdo
