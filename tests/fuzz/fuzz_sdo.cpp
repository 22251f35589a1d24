// libFuzzer harness: common's SDO server and client fed any sequence of
// frames and clock ticks, and each other's frames. The server must hand its
// dictionary every download in order and within the object's capacity, read
// only inside the object, and touch no memory it does not own (ASan,
// UBSan); the client must keep an upload inside its buffer.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "delta/can/sdo.hpp"

namespace {

namespace sdo = delta::can::sdo;

// Two objects: a 2-byte value and a 40-byte domain.
class Dictionary final : public sdo::ObjectDictionary {
 public:
  sdo::AbortCode find(std::uint16_t index, std::uint8_t sub, sdo::ObjectInfo& info) override {
    if (index == 0x1017 && sub == 0) {
      info = {2, 2, true, true, false};
      return sdo::kNoAbort;
    }
    if (index == 0x1F50 && sub == 1) {
      info = {static_cast<std::uint32_t>(domain_.size()), 40, true, true, true};
      return sdo::kNoAbort;
    }
    return index == 0x1F50 ? sdo::kAbortSubindexDoesNotExist : sdo::kAbortObjectDoesNotExist;
  }
  sdo::AbortCode read(std::uint16_t index, std::uint8_t, std::uint32_t offset,
                      std::span<std::uint8_t> out) override {
    const std::vector<std::uint8_t>& v = index == 0x1017 ? value_ : domain_;
    if (offset + out.size() > v.size()) std::abort();  // read beyond the object
    if (!out.empty()) std::memcpy(out.data(), v.data() + offset, out.size());
    return sdo::kNoAbort;
  }
  sdo::AbortCode write(std::uint16_t index, std::uint8_t, std::uint32_t offset,
                       std::span<const std::uint8_t> data, bool last) override {
    if (offset == 0) staged_.clear();
    if (offset != staged_.size()) std::abort();  // out of order
    staged_.insert(staged_.end(), data.begin(), data.end());
    if (staged_.size() > (index == 0x1017 ? 2u : 40u)) std::abort();  // beyond capacity
    if (last) (index == 0x1017 ? value_ : domain_) = staged_;
    return sdo::kNoAbort;
  }
  void download_abandoned(std::uint16_t, std::uint8_t) override { staged_.clear(); }

 private:
  std::vector<std::uint8_t> value_{0x10, 0x00};
  std::vector<std::uint8_t> domain_ = std::vector<std::uint8_t>(20, 0xAB);
  std::vector<std::uint8_t> staged_;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Dictionary dictionary;
  sdo::Server server(dictionary, 1000, 4);
  sdo::Client client(1000, 3);
  std::vector<std::uint8_t> upload_buffer(30);
  const std::uint8_t download[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17};
  client.download(0x1F50, 1, download, sdo::Transfer::kBlock, 0);
  sdo::TimeUs now = 0;
  // Each record: 1 byte of what to do, 8 bytes of frame.
  for (std::size_t at = 0; at + 9 <= size; at += 9) {
    sdo::Payload frame;
    std::memcpy(frame.data(), data + at + 1, 8);
    const std::uint8_t op = data[at];
    now += op >> 4;
    if ((op & 3) == 0) server.on_frame(frame, now);
    if ((op & 3) == 1) client.on_frame(frame, now);
    if ((op & 3) == 2) {
      server.tick(now * 100);
      client.tick(now * 100);
    }
    if ((op & 3) == 3 && client.status() != sdo::ClientStatus::kBusy) {
      client.upload(0x1F50, 1, upload_buffer,
                    (op & 4) ? sdo::Transfer::kBlock : sdo::Transfer::kAuto, now);
    }
    sdo::Payload out;
    for (int n = 0; n < 300 && server.pending(out); ++n) {
      server.sent(now);
      if (op & 8) client.on_frame(out, now);
    }
    for (int n = 0; n < 300 && client.pending(out); ++n) {
      client.sent(now);
      if (op & 8) server.on_frame(out, now);
    }
    if (client.uploaded_size() > upload_buffer.size()) std::abort();
  }
  return 0;
}
