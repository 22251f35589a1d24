// The SDO client and server (delta/can/sdo.hpp): frame-exact conversations
// written by hand from CiA 301's protocol descriptions, round trips of our
// client with our server through a link that can drop, corrupt and hold
// frames, every abort, and the timeouts.
#include "delta/can/sdo.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

namespace delta::can::sdo {
namespace {

// ---- A test object dictionary ----

struct Entry {
  std::vector<std::uint8_t> value;
  bool readable{true};
  bool writable{true};
  bool variable_length{false};
  std::uint32_t capacity{0};
  std::uint32_t max_value{0xFFFFFFFF};  // checked on the last piece of a scalar
};

class TestDictionary final : public ObjectDictionary {
 public:
  TestDictionary() {
    add(0x1000, 0, {0x92, 0x01, 0x02, 0x00}, true, false);  // device type, read-only
    add(0x1017, 0, {0xE8, 0x03}, true, true);               // heartbeat time, UNSIGNED16
    add(0x6060, 0, {0x0A}, true, true);                     // modes of operation, INTEGER8
    entries_[{0x6060, 0}].max_value = 10;
    add(0x6071, 0, {0, 0, 0, 0}, false, true);  // a write-only INTEGER32 here
    const std::string name = "Delta emulated drive";
    Entry device_name{std::vector<std::uint8_t>(name.begin(), name.end()), true, false, true, 64};
    entries_[{0x1008, 0}] = device_name;
    entries_[{0x1F50, 1}] = Entry{{}, true, true, true, 200000};  // program data (domain)
    entries_[{0x2000, 0}] = Entry{{}, true, true, true, 64};      // a writable string
  }

  void add(std::uint16_t index, std::uint8_t sub, std::vector<std::uint8_t> v, bool r, bool w) {
    Entry e;
    e.value = std::move(v);
    e.readable = r;
    e.writable = w;
    e.capacity = static_cast<std::uint32_t>(e.value.size());
    entries_[{index, sub}] = e;
  }

  AbortCode find(std::uint16_t index, std::uint8_t sub, ObjectInfo& info) override {
    const auto it = entries_.find({index, sub});
    if (it == entries_.end()) {
      for (const auto& [key, e] : entries_) {
        if (key.first == index) return kAbortSubindexDoesNotExist;
      }
      return kAbortObjectDoesNotExist;
    }
    const Entry& e = it->second;
    info.size = static_cast<std::uint32_t>(e.value.size());
    info.capacity = e.capacity;
    info.readable = e.readable;
    info.writable = e.writable;
    info.variable_length = e.variable_length;
    return kNoAbort;
  }

  AbortCode read(std::uint16_t index, std::uint8_t sub, std::uint32_t offset,
                 std::span<std::uint8_t> out) override {
    const Entry& e = entries_.at({index, sub});
    if (!out.empty()) std::memcpy(out.data(), e.value.data() + offset, out.size());
    return kNoAbort;
  }

  AbortCode write(std::uint16_t index, std::uint8_t sub, std::uint32_t offset,
                  std::span<const std::uint8_t> data, bool last) override {
    if (offset == 0) staged_.clear();
    EXPECT_EQ(offset, staged_.size()) << "pieces arrive in order";
    if (offset >= refuse_from) return kAbortCannotStore;
    staged_.insert(staged_.end(), data.begin(), data.end());
    ++writes;
    if (!last) return kNoAbort;
    Entry& e = entries_.at({index, sub});
    if (!e.variable_length) {
      std::uint32_t v = 0;
      for (std::size_t i = 0; i < staged_.size() && i < 4; ++i)
        v |= std::uint32_t{staged_[i]} << (8 * i);
      if (v > e.max_value) return kAbortValueTooHigh;
    }
    e.value = staged_;
    return kNoAbort;
  }

  void download_abandoned(std::uint16_t, std::uint8_t) override {
    staged_.clear();
    ++abandoned;
  }

  const std::vector<std::uint8_t>& value(std::uint16_t index, std::uint8_t sub) const {
    return entries_.at({index, sub}).value;
  }

  int writes{0};
  int abandoned{0};
  std::uint32_t refuse_from{0xFFFFFFFF};  // a write at this offset or later is refused

 private:
  std::map<std::pair<std::uint16_t, std::uint8_t>, Entry> entries_;
  std::vector<std::uint8_t> staged_;
};

// ---- Frames written as bytes ----

Payload frame(std::initializer_list<int> bytes) {
  Payload p{};
  std::size_t i = 0;
  for (const int b : bytes) p[i++] = static_cast<std::uint8_t>(b);
  return p;
}

std::string hex(const Payload& p) {
  std::string s;
  char buf[4];
  for (const std::uint8_t b : p) {
    std::snprintf(buf, sizeof buf, "%02X ", b);
    s += buf;
  }
  s.pop_back();
  return s;
}

// Sends one request to the server and returns every frame it answers with.
std::vector<std::string> ask(Server& server, const Payload& request, TimeUs now = 0) {
  server.on_frame(request, now);
  std::vector<std::string> out;
  Payload p;
  while (server.pending(p)) {
    out.push_back(hex(p));
    server.sent(now);
  }
  return out;
}

using Frames = std::vector<std::string>;

// ---- CiA 301 conversations, byte by byte ----

TEST(SdoCrcTest, IsCrc16CcittWithInitialValueZero) {
  const std::string check = "123456789";
  EXPECT_EQ(crc16(0, std::span(reinterpret_cast<const std::uint8_t*>(check.data()), check.size())),
            0x31C3);
  EXPECT_EQ(crc16(0, {}), 0x0000);
}

TEST(SdoAbortTest, EveryCodeHasCiA301sMeaning) {
  EXPECT_STREQ(abort_meaning(0x06070010),
               "data type does not match, length of service parameter does not match");
  EXPECT_STREQ(abort_meaning(0x05040004), "CRC error");
  EXPECT_STREQ(abort_meaning(0x08000022),
               "data cannot be transferred or stored to the application because of the present "
               "device state");
  EXPECT_STREQ(abort_meaning(0x12345678), "unknown abort code");
}

TEST(SdoServerTest, ExpeditedDownloadWithAndWithoutTheSizeIndicated) {
  TestDictionary od;
  Server server(od);
  // 0x2B: two bytes, size indicated; heartbeat time 1000 -> 500 ms.
  EXPECT_EQ(ask(server, frame({0x2B, 0x17, 0x10, 0x00, 0xF4, 0x01, 0x00, 0x00})),
            Frames{"60 17 10 00 00 00 00 00"});
  EXPECT_EQ(od.value(0x1017, 0), (std::vector<std::uint8_t>{0xF4, 0x01}));
  // 0x22: expedited, size not indicated: the object's two bytes apply.
  EXPECT_EQ(ask(server, frame({0x22, 0x17, 0x10, 0x00, 0x64, 0x00, 0xAA, 0xBB})),
            Frames{"60 17 10 00 00 00 00 00"});
  EXPECT_EQ(od.value(0x1017, 0), (std::vector<std::uint8_t>{0x64, 0x00}));
  EXPECT_TRUE(server.idle());
}

TEST(SdoServerTest, ADownloadOfTheWrongLengthIsAbortedAndNotStored) {
  TestDictionary od;
  Server server(od);
  // INTEGER8 0x6060 written with 2 and 4 bytes; UNSIGNED16 0x1017 with 1 and 4.
  EXPECT_EQ(ask(server, frame({0x2B, 0x60, 0x60, 0x00, 0x0A, 0x00})),
            Frames{"80 60 60 00 12 00 07 06"});
  EXPECT_EQ(ask(server, frame({0x23, 0x60, 0x60, 0x00, 0x0A})), Frames{"80 60 60 00 12 00 07 06"});
  EXPECT_EQ(ask(server, frame({0x2F, 0x17, 0x10, 0x00, 0x0A})), Frames{"80 17 10 00 13 00 07 06"});
  EXPECT_EQ(ask(server, frame({0x23, 0x17, 0x10, 0x00, 0x0A})), Frames{"80 17 10 00 12 00 07 06"});
  EXPECT_EQ(od.value(0x1017, 0), (std::vector<std::uint8_t>{0xE8, 0x03}));
  EXPECT_EQ(od.value(0x6060, 0), (std::vector<std::uint8_t>{0x0A}));
  EXPECT_EQ(od.writes, 0);
}

TEST(SdoServerTest, ExpeditedUploadAnswersWithTheObjectsOwnSize) {
  TestDictionary od;
  Server server(od);
  EXPECT_EQ(ask(server, frame({0x40, 0x60, 0x60, 0x00})), Frames{"4F 60 60 00 0A 00 00 00"});
  EXPECT_EQ(ask(server, frame({0x40, 0x17, 0x10, 0x00})), Frames{"4B 17 10 00 E8 03 00 00"});
  EXPECT_EQ(ask(server, frame({0x40, 0x00, 0x10, 0x00})), Frames{"43 00 10 00 92 01 02 00"});
}

TEST(SdoServerTest, SegmentedUploadOfTheDeviceName) {
  TestDictionary od;
  Server server(od);
  // "Delta emulated drive": 20 bytes = 7 + 7 + 6.
  EXPECT_EQ(ask(server, frame({0x40, 0x08, 0x10, 0x00})), Frames{"41 08 10 00 14 00 00 00"});
  EXPECT_EQ(ask(server, frame({0x60})), Frames{"00 44 65 6C 74 61 20 65"});  // "Delta e"
  EXPECT_EQ(ask(server, frame({0x70})), Frames{"10 6D 75 6C 61 74 65 64"});  // "mulated"
  EXPECT_EQ(ask(server, frame({0x60})), Frames{"03 20 64 72 69 76 65 00"});  // " drive", n=1, c
  EXPECT_TRUE(server.idle());
}

TEST(SdoServerTest, AToggleBitThatDoesNotAlternateAborts) {
  TestDictionary od;
  Server server(od);
  ask(server, frame({0x40, 0x08, 0x10, 0x00}));
  ask(server, frame({0x60}));
  EXPECT_EQ(ask(server, frame({0x60})), Frames{"80 08 10 00 00 00 03 05"});
  EXPECT_TRUE(server.idle());
  // Downloads too; the half-written object is abandoned, not stored.
  ask(server, frame({0x21, 0x00, 0x20, 0x00, 0x0A, 0x00, 0x00, 0x00}));
  EXPECT_EQ(ask(server, frame({0x00, 1, 2, 3, 4, 5, 6, 7})), Frames{"20 00 00 00 00 00 00 00"});
  EXPECT_EQ(ask(server, frame({0x05, 8, 9, 10})), Frames{"80 00 20 00 00 00 03 05"});
  EXPECT_EQ(od.abandoned, 1);
  EXPECT_TRUE(od.value(0x2000, 0).empty());
}

TEST(SdoServerTest, SegmentedDownloadOfAString) {
  TestDictionary od;
  Server server(od);
  EXPECT_EQ(ask(server, frame({0x21, 0x00, 0x20, 0x00, 0x0A, 0x00, 0x00, 0x00})),
            Frames{"60 00 20 00 00 00 00 00"});
  EXPECT_EQ(ask(server, frame({0x00, 'p', 'i', 'c', 'k', '-', 'a', 'n'})),
            Frames{"20 00 00 00 00 00 00 00"});
  // Toggle 1, n = 4 unused bytes, c: 0x10 | 4 << 1 | 1 = 0x19.
  EXPECT_EQ(ask(server, frame({0x19, 'd', '-', 'p'})), Frames{"30 00 00 00 00 00 00 00"});
  const std::string stored(od.value(0x2000, 0).begin(), od.value(0x2000, 0).end());
  EXPECT_EQ(stored, "pick-and-p");
}

TEST(SdoServerTest, BlockDownloadWithCrc) {
  TestDictionary od;
  Server server(od);
  const std::vector<std::uint8_t> data{0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  const std::uint16_t crc = crc16(0, data);
  // Initiate: ccs 6, CRC supported, size indicated (0xC6), 10 bytes; the
  // server answers 0xA4 (CRC supported) and its block size, 127.
  EXPECT_EQ(ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0x0A, 0x00, 0x00, 0x00})),
            Frames{"A4 50 1F 01 7F 00 00 00"});
  EXPECT_TRUE(ask(server, frame({0x01, 0, 1, 2, 3, 4, 5, 6})).empty());
  // The last segment (0x80 | 2) ends the block: acknowledged up to 2.
  EXPECT_EQ(ask(server, frame({0x82, 7, 8, 9, 0, 0, 0, 0})), Frames{"A2 02 7F 00 00 00 00 00"});
  // End: 4 bytes of the last segment unused (0xC1 | 4 << 2), the CRC.
  EXPECT_EQ(ask(server, frame({0xD1, crc & 0xFF, crc >> 8})), Frames{"A1 00 00 00 00 00 00 00"});
  EXPECT_EQ(od.value(0x1F50, 1), data);
}

TEST(SdoServerTest, ABlockDownloadWithAWrongCrcIsAbortedAndAbandoned) {
  TestDictionary od;
  Server server(od);
  ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0x0A, 0x00, 0x00, 0x00}));
  ask(server, frame({0x01, 0, 1, 2, 3, 4, 5, 6}));
  ask(server, frame({0x82, 7, 8, 9}));
  EXPECT_EQ(ask(server, frame({0xD1, 0x12, 0x34})), Frames{"80 50 1F 01 04 00 04 05"});
  EXPECT_EQ(od.abandoned, 1);
  EXPECT_TRUE(od.value(0x1F50, 1).empty());
}

// The node refuses a block download mid-block (a firmware image for other
// hardware, seen once its header is in): the client has sent the rest of
// the block already. Those segments are the aborted transfer's, not
// requests: no answers, no objects written from their bytes, and the
// client's next request is answered as usual.
TEST(SdoServerTest, TheRestOfAnAbortedBlockIsNotTakenForRequests) {
  TestDictionary od;
  od.refuse_from = 14;  // refused when segment 4 arrives, with segment 3 held
  Server server(od);
  ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0xD0, 0x07, 0x00, 0x00}));  // 2000 bytes
  std::vector<std::string> answers;
  for (int seq = 1; seq <= 127; ++seq) {
    // Segment bytes chosen to look like requests: an expedited write of
    // 0x1017 (heartbeat time) = 0.
    for (const std::string& a : ask(server, frame({seq, 0x17, 0x10, 0x00, 0, 0, 0, 0}))) {
      answers.push_back(a);
    }
  }
  EXPECT_EQ(answers, Frames{"80 50 1F 01 20 00 00 08"}) << "the abort, once";
  EXPECT_EQ(od.abandoned, 1);
  EXPECT_EQ(od.value(0x1017, 0), (std::vector<std::uint8_t>{0xE8, 0x03})) << "not written";
  EXPECT_EQ(ask(server, frame({0x40, 0x00, 0x10, 0x00})), Frames{"43 00 10 00 92 01 02 00"});
}

TEST(SdoServerTest, ASegmentOutOfSequenceIsAskedForAgain) {
  TestDictionary od;
  Server server(od, kDefaultTimeoutUs, 4);
  EXPECT_EQ(ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0x15, 0x00, 0x00, 0x00})),
            Frames{"A4 50 1F 01 04 00 00 00"});
  ask(server, frame({0x01, 0, 1, 2, 3, 4, 5, 6}));
  // Segment 2 lost: 3 is dropped, and the block's end acknowledges 1 only.
  EXPECT_EQ(ask(server, frame({0x83, 14, 15, 16, 17, 18, 19, 20})),
            Frames{"A2 01 04 00 00 00 00 00"});
  ask(server, frame({0x01, 7, 8, 9, 10, 11, 12, 13}));
  EXPECT_EQ(ask(server, frame({0x82, 14, 15, 16, 17, 18, 19, 20})),
            Frames{"A2 02 04 00 00 00 00 00"});
  std::vector<std::uint8_t> data(21);
  std::iota(data.begin(), data.end(), 0);
  const std::uint16_t crc = crc16(0, data);
  EXPECT_EQ(ask(server, frame({0xC1, crc & 0xFF, crc >> 8})), Frames{"A1 00 00 00 00 00 00 00"});
  EXPECT_EQ(od.value(0x1F50, 1), data);
}

TEST(SdoServerTest, BlockUploadSendsTheBlockThenTheCrc) {
  TestDictionary od;
  Server server(od);
  // ccs 5, CRC supported (0xA4), block size 2, no protocol switch.
  EXPECT_EQ(ask(server, frame({0xA4, 0x08, 0x10, 0x00, 0x02, 0x00})),
            Frames{"C6 08 10 00 14 00 00 00"});
  EXPECT_EQ(ask(server, frame({0xA3})),
            (Frames{"01 44 65 6C 74 61 20 65", "02 6D 75 6C 61 74 65 64"}));
  // The next block numbers from 1 again: 0x80 | 1 carries the last byte.
  EXPECT_EQ(ask(server, frame({0xA2, 0x02, 0x02})), Frames{"81 20 64 72 69 76 65 00"});
  const std::string name = "Delta emulated drive";
  const std::uint16_t crc =
      crc16(0, std::span(reinterpret_cast<const std::uint8_t*>(name.data()), name.size()));
  const Frames end = ask(server, frame({0xA2, 0x01, 0x02}));
  // 20 bytes: the last segment has 6, 1 unused (0xC1 | 1 << 2 = 0xC5).
  ASSERT_EQ(end.size(), 1u);
  EXPECT_EQ(end[0], hex(frame({0xC5, crc & 0xFF, crc >> 8})));
  EXPECT_TRUE(ask(server, frame({0xA1})).empty());
  EXPECT_TRUE(server.idle());
}

TEST(SdoServerTest, EachRefusalHasItsAbortCode) {
  TestDictionary od;
  Server server(od);
  EXPECT_EQ(ask(server, frame({0x40, 0x34, 0x12, 0x00})), Frames{"80 34 12 00 00 00 02 06"});
  EXPECT_EQ(ask(server, frame({0x40, 0x17, 0x10, 0x05})), Frames{"80 17 10 05 11 00 09 06"});
  EXPECT_EQ(ask(server, frame({0x23, 0x00, 0x10, 0x00, 1})), Frames{"80 00 10 00 02 00 01 06"});
  EXPECT_EQ(ask(server, frame({0x40, 0x71, 0x60, 0x00})), Frames{"80 71 60 00 01 00 01 06"});
  EXPECT_EQ(ask(server, frame({0x2F, 0x60, 0x60, 0x00, 11})), Frames{"80 60 60 00 31 00 09 06"});
  EXPECT_EQ(ask(server, frame({0xE0, 0x00, 0x10, 0x00})), Frames{"80 00 00 00 01 00 04 05"});
  EXPECT_EQ(ask(server, frame({0x60})), Frames{"80 00 00 00 01 00 04 05"});  // no transfer
  EXPECT_EQ(ask(server, frame({0xA4, 0x08, 0x10, 0x00, 0x00})), Frames{"80 08 10 00 02 00 04 05"});
  EXPECT_EQ(ask(server, frame({0xA4, 0x08, 0x10, 0x00, 0x80})), Frames{"80 08 10 00 02 00 04 05"});
  ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0x0A}));
  EXPECT_EQ(ask(server, frame({0x00})), Frames{"80 50 1F 01 03 00 04 05"});  // sequence 0
  // A domain written beyond what it can hold.
  EXPECT_EQ(ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0x41, 0x0D, 0x03, 0x00})),
            Frames{"80 50 1F 01 12 00 07 06"});
  EXPECT_TRUE(server.idle());
}

TEST(SdoServerTest, AClientThatFallsSilentIsAbortedAfterTheTimeout) {
  TestDictionary od;
  Server server(od, 100'000);
  ask(server, frame({0x21, 0x00, 0x20, 0x00, 0x0A}), 1'000);
  ask(server, frame({0x00, 1, 2, 3, 4, 5, 6, 7}), 50'000);
  server.tick(149'999);  // 100 ms after the last request, not yet
  Payload p;
  EXPECT_FALSE(server.pending(p));
  server.tick(150'000);
  ASSERT_TRUE(server.pending(p));
  EXPECT_EQ(hex(p), "80 00 20 00 00 00 04 05");
  EXPECT_EQ(od.abandoned, 1);
}

TEST(SdoServerTest, AClientAbortEndsTheTransferWithoutAnswer) {
  TestDictionary od;
  Server server(od);
  ask(server, frame({0xC6, 0x50, 0x1F, 0x01, 0x0A}));
  ask(server, frame({0x01, 0, 1, 2, 3, 4, 5, 6}));
  EXPECT_TRUE(ask(server, frame({0x80, 0x50, 0x1F, 0x01, 0x00, 0x00, 0x04, 0x05})).empty());
  EXPECT_TRUE(server.idle());
  EXPECT_EQ(od.abandoned, 1);
}

// ---- Our client against our server ----

// Carries frames between a client and a server. `on_request` and
// `on_response` may change or drop a frame (return false); `hold_us` makes
// the bus take each frame that long after it is offered (a full queue).
struct Link {
  Client& client;
  Server& server;
  std::function<bool(Payload&, int)> on_request = [](Payload&, int) { return true; };
  std::function<bool(Payload&, int)> on_response = [](Payload&, int) { return true; };
  TimeUs now{0};
  TimeUs hold_us{0};
  int requests{0};
  int responses{0};

  // Runs until the client has finished and no frame is left.
  void run(TimeUs step_us = 100, TimeUs limit_us = 60'000'000) {
    for (; now < limit_us; now += step_us) {
      bool moved = false;
      Payload p;
      while (client.pending(p)) {
        now += hold_us;
        client.sent(now);
        moved = true;
        if (on_request(p, requests++)) server.on_frame(p, now);
      }
      while (server.pending(p)) {
        now += hold_us;
        server.sent(now);
        moved = true;
        if (on_response(p, responses++)) client.on_frame(p, now);
      }
      if (!moved && client.status() != ClientStatus::kBusy) return;
      client.tick(now);
      server.tick(now);
    }
    FAIL() << "the transfer did not end";
  }
};

std::vector<std::uint8_t> pattern(std::size_t n) {
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>((i * 131 + 7) & 0xFF);
  return v;
}

class SdoRoundTripTest : public ::testing::TestWithParam<std::pair<Transfer, std::size_t>> {};

TEST_P(SdoRoundTripTest, WhatIsDownloadedUploadsTheSame) {
  const auto [transfer, size] = GetParam();
  TestDictionary od;
  Server server(od);
  Client client;
  Link link{client, server};
  const std::vector<std::uint8_t> data = pattern(size);
  client.download(0x1F50, 1, data, transfer, 0);
  link.run();
  ASSERT_EQ(client.status(), ClientStatus::kDone) << abort_meaning(client.abort_code());
  EXPECT_EQ(od.value(0x1F50, 1), data);
  std::vector<std::uint8_t> back(size + 10, 0xEE);
  client.upload(0x1F50, 1, back, transfer, link.now);
  link.run();
  ASSERT_EQ(client.status(), ClientStatus::kDone) << abort_meaning(client.abort_code());
  ASSERT_EQ(client.uploaded_size(), size);
  back.resize(size);
  EXPECT_EQ(back, data);
  EXPECT_TRUE(server.idle());
}

INSTANTIATE_TEST_SUITE_P(
    EverySizeAtTheEdges, SdoRoundTripTest,
    ::testing::Values(std::pair{Transfer::kAuto, 0}, std::pair{Transfer::kAuto, 1},
                      std::pair{Transfer::kAuto, 4}, std::pair{Transfer::kAuto, 5},
                      std::pair{Transfer::kAuto, 7}, std::pair{Transfer::kAuto, 8},
                      std::pair{Transfer::kSegmented, 3}, std::pair{Transfer::kSegmented, 14},
                      std::pair{Transfer::kSegmented, 1000}, std::pair{Transfer::kBlock, 0},
                      std::pair{Transfer::kBlock, 1}, std::pair{Transfer::kBlock, 7},
                      std::pair{Transfer::kBlock, 8}, std::pair{Transfer::kBlock, 889},
                      std::pair{Transfer::kBlock, 890}, std::pair{Transfer::kBlock, 100'000}));

TEST(SdoClientTest, SegmentedAndBlockTransfersTakeTheFramesCiA301Gives) {
  TestDictionary od;
  Server server(od);
  Client client;
  Link link{client, server};
  const std::vector<std::uint8_t> data = pattern(1000);  // 143 segments
  client.download(0x1F50, 1, data, Transfer::kSegmented, 0);
  link.run();
  EXPECT_EQ(link.requests, 1 + 143);
  EXPECT_EQ(link.responses, 1 + 143);
  link.requests = link.responses = 0;
  client.download(0x1F50, 1, data, Transfer::kBlock, link.now);
  link.run();
  // Initiate, 127 + 16 segments, end; the server: initiate, two acks, end.
  EXPECT_EQ(link.requests, 1 + 143 + 1);
  EXPECT_EQ(link.responses, 4);
}

TEST(SdoClientTest, LostSegmentsAreSentAgainBothWays) {
  TestDictionary od;
  Server server(od, kDefaultTimeoutUs, 16);
  Client client(kDefaultTimeoutUs, 16);
  Link link{client, server};
  const std::vector<std::uint8_t> data = pattern(5000);
  // Drop the 5th, 40th and 300th request frames (block segments).
  link.on_request = [](Payload&, int n) { return n != 5 && n != 40 && n != 300; };
  client.download(0x1F50, 1, data, Transfer::kBlock, 0);
  link.run();
  ASSERT_EQ(client.status(), ClientStatus::kDone) << abort_meaning(client.abort_code());
  EXPECT_EQ(od.value(0x1F50, 1), data);
  link.on_request = [](Payload&, int) { return true; };
  link.responses = 0;
  link.on_response = [](Payload&, int n) { return n != 3 && n != 17 && n != 200; };
  std::vector<std::uint8_t> back(data.size());
  client.upload(0x1F50, 1, back, Transfer::kBlock, link.now);
  link.run();
  ASSERT_EQ(client.status(), ClientStatus::kDone) << abort_meaning(client.abort_code());
  EXPECT_EQ(back, data);
}

TEST(SdoClientTest, ACorruptedBlockSegmentFailsTheCrcCheck) {
  TestDictionary od;
  Server server(od);
  Client client;
  Link link{client, server};
  const std::vector<std::uint8_t> data = pattern(100);
  link.on_request = [](Payload& p, int n) {
    if (n == 3) p[4] ^= 0x01;  // one bit of the third segment
    return true;
  };
  client.download(0x1F50, 1, data, Transfer::kBlock, 0);
  link.run();
  EXPECT_EQ(client.status(), ClientStatus::kAborted);
  EXPECT_EQ(client.abort_code(), kAbortCrc);
  EXPECT_TRUE(client.aborted_by_server());
  EXPECT_TRUE(od.value(0x1F50, 1).empty());
  // Uploads: the client checks.
  client.download(0x1F50, 1, data, Transfer::kBlock, link.now);
  link.on_request = [](Payload&, int) { return true; };
  link.run();
  ASSERT_EQ(client.status(), ClientStatus::kDone);
  link.responses = 0;
  link.on_response = [](Payload& p, int n) {
    if (n == 2) p[7] ^= 0x80;
    return true;
  };
  std::vector<std::uint8_t> back(100);
  client.upload(0x1F50, 1, back, Transfer::kBlock, link.now);
  link.run();
  EXPECT_EQ(client.status(), ClientStatus::kAborted);
  EXPECT_EQ(client.abort_code(), kAbortCrc);
  EXPECT_FALSE(client.aborted_by_server());
  EXPECT_TRUE(server.idle()) << "the client's abort reached the server";
}

TEST(SdoClientTest, AServerThatDoesNotAnswerTimesOut) {
  TestDictionary od;
  Server server(od);
  Client client(200'000);
  Link link{client, server};
  link.on_request = [](Payload&, int n) { return n < 2; };  // the bus breaks after 2 frames
  const std::vector<std::uint8_t> data = pattern(30);
  client.download(0x2000, 0, data, Transfer::kSegmented, 0);
  link.run(1000);
  EXPECT_EQ(client.status(), ClientStatus::kAborted);
  EXPECT_EQ(client.abort_code(), kAbortTimeout);
  EXPECT_FALSE(client.aborted_by_server());
  EXPECT_GE(link.now, 200'000u);
  EXPECT_LT(link.now, 210'000u);
}

TEST(SdoClientTest, AFullTransmitQueuePacesTheTransferInsteadOfTimingOut) {
  TestDictionary od;
  Server server(od, 100'000);
  Client client(100'000, 127);
  Link link{client, server};
  link.hold_us = 5'000;  // 127 segments take 635 ms to leave, over six timeouts
  const std::vector<std::uint8_t> data = pattern(3000);
  client.download(0x1F50, 1, data, Transfer::kBlock, 0);
  link.run();
  ASSERT_EQ(client.status(), ClientStatus::kDone) << abort_meaning(client.abort_code());
  EXPECT_EQ(od.value(0x1F50, 1), data);
  EXPECT_GT(link.now, 2'000'000u);
}

TEST(SdoClientTest, ServerAbortsReachTheClientWithTheirCode) {
  TestDictionary od;
  Server server(od);
  Client client;
  Link link{client, server};
  const std::uint8_t value[] = {11};
  client.download(0x6060, 0, value, Transfer::kAuto, 0);
  link.run();
  EXPECT_EQ(client.status(), ClientStatus::kAborted);
  EXPECT_EQ(client.abort_code(), kAbortValueTooHigh);
  EXPECT_TRUE(client.aborted_by_server());
  std::vector<std::uint8_t> small(10);
  client.upload(0x1008, 0, small, Transfer::kAuto, link.now);
  link.run();
  EXPECT_EQ(client.abort_code(), kAbortOutOfMemory);
  EXPECT_FALSE(client.aborted_by_server());
  EXPECT_TRUE(server.idle());
  client.upload(0x1008, 0, small, Transfer::kBlock, link.now);
  link.run();
  EXPECT_EQ(client.abort_code(), kAbortOutOfMemory);
  EXPECT_TRUE(server.idle());
}

TEST(SdoClientTest, AServerResponseWithTheWrongToggleIsAborted) {
  Client client;
  std::vector<std::uint8_t> buffer(20);
  client.upload(0x1008, 0, buffer, Transfer::kAuto, 0);
  Payload p;
  ASSERT_TRUE(client.pending(p));
  EXPECT_EQ(hex(p), "40 08 10 00 00 00 00 00");
  client.sent(0);
  client.on_frame(frame({0x41, 0x08, 0x10, 0x00, 0x14}), 10);
  ASSERT_TRUE(client.pending(p));
  EXPECT_EQ(hex(p), "60 00 00 00 00 00 00 00");
  client.sent(10);
  client.on_frame(frame({0x10, 'D', 'e', 'l', 't', 'a', ' ', 'e'}), 20);  // toggle 1, expected 0
  EXPECT_EQ(client.status(), ClientStatus::kAborted);
  EXPECT_EQ(client.abort_code(), kAbortToggleBit);
  ASSERT_TRUE(client.pending(p));
  EXPECT_EQ(hex(p), "80 08 10 00 00 00 03 05");
}

}  // namespace
}  // namespace delta::can::sdo

namespace delta::can::sdo {
namespace {

// A request that timed out and was repeated may be answered twice; the
// late answer names the earlier object and must not end the new transfer.
TEST(SdoClientTest, ALateAnswerAboutAnotherObjectIsIgnored) {
  Client client(100'000);
  std::vector<std::uint8_t> buffer(4);
  client.upload(0x6075, 0, buffer, Transfer::kAuto, 0);
  client.sent(0);
  EXPECT_EQ(client.deadline_us(), 100'000u);
  client.on_frame(frame({0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}), 10);  // 0x1000's
  client.on_frame(frame({0x80, 0x00, 0x10, 0x00, 0x00, 0x00, 0x02, 0x06}), 20);  // an old abort
  EXPECT_EQ(client.status(), ClientStatus::kBusy);
  client.on_frame(frame({0x43, 0x75, 0x60, 0x00, 0xB8, 0x0B, 0x00, 0x00}), 30);
  ASSERT_EQ(client.status(), ClientStatus::kDone);
  EXPECT_EQ(client.uploaded_size(), 4u);
  EXPECT_EQ(buffer[0] | buffer[1] << 8, 3000);
  EXPECT_EQ(client.deadline_us(), 0u);
}

}  // namespace
}  // namespace delta::can::sdo
