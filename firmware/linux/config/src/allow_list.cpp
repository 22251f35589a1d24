#include "fw_linux/allow_list.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <cstring>

#include "fw_linux/config.hpp"

namespace fw_linux {

namespace {

std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

AllowedNetwork parse_network(const std::string& entry, const std::string& where) {
  const auto slash = entry.find('/');
  const std::string address = entry.substr(0, slash);
  AllowedNetwork n;
  if (inet_pton(AF_INET, address.c_str(), n.address.data()) == 1) {
    n.family = AF_INET;
  } else if (inet_pton(AF_INET6, address.c_str(), n.address.data()) == 1) {
    n.family = AF_INET6;
  } else {
    throw ConfigError(where + ": modbus.allow: '" + entry +
                      "' is not an IPv4 or IPv6 address (NET/BITS, e.g. 192.168.10.0/24)");
  }
  const unsigned most = n.family == AF_INET ? 32 : 128;
  n.prefix_bits = most;
  if (slash != std::string::npos) {
    const std::string bits = entry.substr(slash + 1);
    char* end = nullptr;
    const unsigned long b = std::strtoul(bits.c_str(), &end, 10);
    if (bits.empty() || *end != '\0' || b > most) {
      throw ConfigError(where + ": modbus.allow: '" + entry + "': the prefix must be 0 to " +
                        std::to_string(most) + " bits");
    }
    n.prefix_bits = static_cast<unsigned>(b);
  }
  return n;
}

bool same_prefix(const std::uint8_t* a, const std::uint8_t* b, unsigned bits) {
  const unsigned whole = bits / 8, rest = bits % 8;
  if (std::memcmp(a, b, whole) != 0) return false;
  if (rest == 0) return true;
  const auto mask = static_cast<std::uint8_t>(0xFF << (8 - rest));
  return (a[whole] & mask) == (b[whole] & mask);
}

}  // namespace

std::vector<AllowedNetwork> parse_allow_list(const std::string& text, const std::string& where) {
  std::vector<AllowedNetwork> out;
  std::size_t from = 0;
  while (from <= text.size()) {
    const auto comma = text.find(',', from);
    const std::string entry =
        trimmed(text.substr(from, comma == std::string::npos ? std::string::npos : comma - from));
    if (!entry.empty()) out.push_back(parse_network(entry, where));
    if (comma == std::string::npos) break;
    from = comma + 1;
  }
  return out;
}

bool allowed(const std::vector<AllowedNetwork>& networks, const sockaddr_storage& peer) {
  int family = peer.ss_family;
  const std::uint8_t* address = nullptr;
  const auto* v4 = reinterpret_cast<const sockaddr_in*>(&peer);
  const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&peer);
  if (family == AF_INET) {
    address = reinterpret_cast<const std::uint8_t*>(&v4->sin_addr);
  } else if (family == AF_INET6) {
    address = v6->sin6_addr.s6_addr;
    if (IN6_IS_ADDR_V4MAPPED(&v6->sin6_addr)) {
      family = AF_INET;
      address += 12;
    }
  } else {
    return false;
  }
  for (const AllowedNetwork& n : networks) {
    if (n.family == family && same_prefix(n.address.data(), address, n.prefix_bits)) return true;
  }
  return false;
}

std::string address_text(const sockaddr_storage& peer) {
  char text[INET6_ADDRSTRLEN] = "?";
  if (peer.ss_family == AF_INET) {
    inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(&peer)->sin_addr, text, sizeof text);
  } else if (peer.ss_family == AF_INET6) {
    inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(&peer)->sin6_addr, text,
              sizeof text);
  }
  return text;
}

}  // namespace fw_linux
