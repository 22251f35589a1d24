// Who may write to the Modbus TCP server (`modbus.allow`, docs/modbus.md,
// "Who may write"): networks in CIDR form, IPv4 and IPv6. An IPv4 client
// reaching an IPv6 socket (::ffff:a.b.c.d) is matched as IPv4.
#pragma once

#include <sys/socket.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace fw_linux {

struct AllowedNetwork {
  int family{0};                           // AF_INET or AF_INET6
  std::array<std::uint8_t, 16> address{};  // 4 bytes for AF_INET
  unsigned prefix_bits{0};
};

// The default: the machine itself (127.0.0.1, ::1).
inline constexpr const char* kDefaultModbusAllow = "127.0.0.1/32,::1/128";

// "NET/BITS,..." (a bare address is /32 or /128; "" allows nobody). Throws
// ConfigError naming the entry and `where`.
std::vector<AllowedNetwork> parse_allow_list(const std::string& text, const std::string& where);

// Whether the peer's address is in one of the networks.
bool allowed(const std::vector<AllowedNetwork>& networks, const sockaddr_storage& peer);

// The peer's address as text ("192.0.2.7", "2001:db8::1").
std::string address_text(const sockaddr_storage& peer);

}  // namespace fw_linux
