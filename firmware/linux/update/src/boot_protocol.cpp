#include "fw_linux/boot_protocol.hpp"

#include <charconv>
#include <cstdlib>

#include "fw_linux/config.hpp"

namespace fw_linux::boot {

namespace {

constexpr std::string_view kWords[] = {"staged\n", "start\n", "reset\n", "clear\n", "confirm\n"};

std::uint64_t number(const char* name, std::string_view text, int base, std::uint64_t max) {
  std::uint64_t v = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v, base);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size() || v > max) {
    throw ConfigError(std::string("environment variable ") + name + "='" + std::string(text) +
                      "' is not a number " + (base == 16 ? "in hexadecimal " : "") + "up to " +
                      std::to_string(max));
  }
  return v;
}

const char* variable(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr ? v : "";
}

}  // namespace

std::string_view word(Message m) {
  return kWords[static_cast<unsigned>(m)];
}

std::optional<Message> parse_message(std::string_view line) {
  for (unsigned i = 0; i < std::size(kWords); ++i) {
    if (line == kWords[i].substr(0, kWords[i].size() - 1)) return static_cast<Message>(i);
  }
  return std::nullopt;
}

std::optional<Supervision> supervision_from_environment() {
  const char* fd = std::getenv(kEnvFd);
  if (fd == nullptr) return std::nullopt;
  Supervision s;
  s.fd = static_cast<int>(number(kEnvFd, fd, 10, 1023));
  s.staging_path = variable(kEnvStaging);
  if (s.staging_path.empty()) {
    throw ConfigError(std::string(kEnvFd) + " is set but " + kEnvStaging + " is not");
  }
  s.running_crc32 = static_cast<std::uint32_t>(number(kEnvCrc, variable(kEnvCrc), 16, 0xFFFFFFFF));
  if (const std::string_view staged = variable(kEnvStaged); !staged.empty()) {
    s.staged_crc32 = static_cast<std::uint32_t>(number(kEnvStaged, staged, 16, 0xFFFFFFFF));
  }
  s.trial = std::string_view(variable(kEnvTrial)) == "1";
  s.reverted = static_cast<fw::update::RevertReason>(
      number(kEnvReverted, variable(kEnvReverted), 10, fw::update::kRevertReasonCount - 1));
  s.capacity_bytes =
      static_cast<std::uint32_t>(number(kEnvCapacity, variable(kEnvCapacity), 10, 0xFFFFFFFF));
  const std::string_view key = variable(kEnvPublicKey);
  if (!key.empty()) {
    if (key.size() != 64) {
      throw ConfigError(std::string(kEnvPublicKey) + " must be 64 hexadecimal digits, has " +
                        std::to_string(key.size()) + " characters");
    }
    delta::update::PublicKey k{};
    for (std::size_t i = 0; i < k.size(); ++i) {
      k[i] = static_cast<std::uint8_t>(number(kEnvPublicKey, key.substr(2 * i, 2), 16, 0xFF));
    }
    s.public_key = k;
  }
  return s;
}

}  // namespace fw_linux::boot
