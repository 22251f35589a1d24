#include "fw_linux/mbap_framer.hpp"

#include <cstring>

namespace fw_linux {

MbapFramer::Next MbapFramer::next(std::size_t& frame_length) const {
  if (size_ < kHeader) return Next::kNeedMore;
  const unsigned protocol = (unsigned{buffer_[2]} << 8) | buffer_[3];
  const unsigned length = (unsigned{buffer_[4]} << 8) | buffer_[5];  // unit id + PDU
  if (protocol != 0 || length < 2 || length + 6 > kMaxAdu) return Next::kBadHeader;
  if (size_ < length + 6) return Next::kNeedMore;
  frame_length = length + 6;
  return Next::kFrame;
}

void MbapFramer::consume(std::size_t n) {
  std::memmove(buffer_.data(), buffer_.data() + n, size_ - n);
  size_ -= n;
}

}  // namespace fw_linux
