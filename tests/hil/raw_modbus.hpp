// A Modbus TCP client with raw sockets for the HIL tests: independent of
// the product's Modbus code (libmodbus on both sides would check nothing),
// and able to misbehave on purpose (trickle bytes, connect and leave).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <thread>
#include <vector>

namespace hil {

class RawModbus {
 public:
  // `from`: the loopback source address to connect from (127.0.0.0/8),
  // else the kernel's choice.
  explicit RawModbus(int port, const char* from = nullptr) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (from != nullptr) {
      sockaddr_in source{};
      source.sin_family = AF_INET;
      const bool bound =
          ::inet_pton(AF_INET, from, &source.sin_addr) == 1 &&
          ::bind(fd_, reinterpret_cast<const sockaddr*>(&source), sizeof source) == 0;
      if (!bound) return;  // not connected: the test says so
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
    timeval tv{2, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~RawModbus() { ::close(fd_); }
  RawModbus(const RawModbus&) = delete;
  RawModbus& operator=(const RawModbus&) = delete;
  bool connected() const { return connected_; }
  // Read input registers (function 4): a request, its whole answer.
  std::array<std::uint8_t, 12> request(std::uint16_t address, std::uint16_t count) {
    ++transaction_;
    return {static_cast<std::uint8_t>(transaction_ >> 8),
            static_cast<std::uint8_t>(transaction_),
            0,
            0,
            0,
            6,
            1,
            4,
            static_cast<std::uint8_t>(address >> 8),
            static_cast<std::uint8_t>(address),
            static_cast<std::uint8_t>(count >> 8),
            static_cast<std::uint8_t>(count)};
  }
  std::optional<std::vector<std::uint16_t>> read_input(std::uint16_t address, std::uint16_t count) {
    const auto req = request(address, count);
    if (::send(fd_, req.data(), req.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(req.size())) {
      return std::nullopt;
    }
    return answer(count);
  }
  // The request's bytes one at a time, `gap` apart (a slow-loris client).
  std::optional<std::vector<std::uint16_t>> trickle(std::uint16_t address, std::uint16_t count,
                                                    std::chrono::milliseconds gap,
                                                    const std::atomic<bool>& stop) {
    const auto req = request(address, count);
    for (const std::uint8_t b : req) {
      if (stop.load() || ::send(fd_, &b, 1, MSG_NOSIGNAL) != 1) return std::nullopt;
      std::this_thread::sleep_for(gap);  // the client's pace, not synchronisation
    }
    return answer(count);
  }

  // Write single register (function 6): the answer's function code and its
  // first data byte (the exception code after 0x86), nothing without one.
  std::optional<std::array<std::uint8_t, 2>> write(std::uint16_t address, std::uint16_t value) {
    ++transaction_;
    const std::array<std::uint8_t, 12> req{static_cast<std::uint8_t>(transaction_ >> 8),
                                           static_cast<std::uint8_t>(transaction_),
                                           0,
                                           0,
                                           0,
                                           6,
                                           1,
                                           6,
                                           static_cast<std::uint8_t>(address >> 8),
                                           static_cast<std::uint8_t>(address),
                                           static_cast<std::uint8_t>(value >> 8),
                                           static_cast<std::uint8_t>(value)};
    if (::send(fd_, req.data(), req.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(req.size())) {
      return std::nullopt;
    }
    std::array<std::uint8_t, 9> in{};  // MBAP, function, and a byte: an exception's whole answer
    std::size_t got = 0;
    while (got < in.size()) {
      const ssize_t n = ::recv(fd_, in.data() + got, in.size() - got, 0);
      if (n <= 0) return std::nullopt;
      got += static_cast<std::size_t>(n);
    }
    if (in[7] == 6) {  // the echo's last 3 bytes
      std::array<std::uint8_t, 3> rest{};
      for (std::size_t r = 0; r < rest.size();) {
        const ssize_t n = ::recv(fd_, rest.data() + r, rest.size() - r, 0);
        if (n <= 0) return std::nullopt;
        r += static_cast<std::size_t>(n);
      }
    }
    return std::array<std::uint8_t, 2>{in[7], in[8]};
  }

 private:
  std::optional<std::vector<std::uint16_t>> answer(std::uint16_t count) {
    std::vector<std::uint8_t> in(9 + 2 * std::size_t{count});
    std::size_t got = 0;
    while (got < in.size()) {
      const ssize_t n = ::recv(fd_, in.data() + got, in.size() - got, 0);
      if (n <= 0) return std::nullopt;
      got += static_cast<std::size_t>(n);
    }
    if (in[7] != 4 || in[8] != 2 * count) return std::nullopt;
    std::vector<std::uint16_t> registers(count);
    for (std::size_t i = 0; i < count; ++i) {
      registers[i] = static_cast<std::uint16_t>(in[9 + 2 * i] << 8 | in[10 + 2 * i]);
    }
    return registers;
  }
  int fd_{-1};
  bool connected_{false};
  std::uint16_t transaction_{0};
};

// Input register `address` and the next as one u32 (high word first, as the
// register map's u32 are).
inline std::uint32_t u32_at(const std::vector<std::uint16_t>& registers, std::size_t address) {
  return std::uint32_t{registers.at(address)} << 16 | registers.at(address + 1);
}

}  // namespace hil
