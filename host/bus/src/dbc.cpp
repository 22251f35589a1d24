#include "host_id/dbc.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "delta/can/protocol.hpp"

namespace host_id {

namespace {

namespace p = delta::can::protocol;

std::string node_name(p::Sender s, std::uint8_t node) {
  if (s == p::Sender::kController) return "Controller";
  return "Drive" + std::to_string(node);
}

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

double factor(const p::Scale& s) {
  return static_cast<double>(s.numerator) / static_cast<double>(s.denominator) *
         std::ldexp(1.0, s.power2);
}

}  // namespace

std::string make_dbc() {
  std::ostringstream o;
  o << "VERSION \"delta-can/1\"\n\nNS_ :\n\nBS_:\n\n";
  o << "BU_: Controller Drive1 Drive2 Drive3 Recorder\n\n";
  std::ostringstream comments;
  for (const p::Message& m : p::kMessages) {
    const std::uint8_t first = m.per_node ? p::kFirstDriveNode : 0;
    const std::uint8_t count = m.per_node ? p::kDriveCount : 1;
    for (std::uint8_t k = 0; k < count; ++k) {
      const auto node = static_cast<std::uint8_t>(first + k);
      const std::uint16_t id = p::cob_id(m, node);
      const std::string name =
          m.per_node ? std::string(m.name) + "_" + std::to_string(node) : m.name;
      const std::string sender = node_name(m.sender, node);
      std::string receivers = "Recorder";
      if (m.receiver == p::Receiver::kController) receivers = "Controller,Recorder";
      if (m.receiver == p::Receiver::kDrives) {
        receivers = m.per_node ? "Drive" + std::to_string(node) + ",Recorder"
                               : "Drive1,Drive2,Drive3,Recorder";
      }
      o << "BO_ " << id << " " << name << ": " << static_cast<int>(m.dlc) << " " << sender << "\n";
      for (std::uint8_t i = 0; i < m.signal_count; ++i) {
        const p::Signal& s = m.signals[i];
        const double f = factor(s.scale);
        const double lo = s.is_signed ? -std::ldexp(1.0, s.length - 1) : 0.0;
        const double hi =
            s.is_signed ? std::ldexp(1.0, s.length - 1) - 1.0 : std::ldexp(1.0, s.length) - 1.0;
        o << " SG_ " << s.name << " : " << static_cast<int>(s.start_bit) << "|"
          << static_cast<int>(s.length) << "@1" << (s.is_signed ? "-" : "+") << " (" << number(f)
          << ",0) [" << number(lo * f) << "|" << number(hi * f) << "] \"" << s.unit << "\" "
          << receivers << "\n";
        comments << "CM_ SG_ " << id << " " << s.name << " \"" << s.comment << "\";\n";
      }
      o << "\n";
      comments << "CM_ BO_ " << id << " \"" << m.comment << "\";\n";
    }
  }
  o << comments.str();
  return o.str();
}

}  // namespace host_id
