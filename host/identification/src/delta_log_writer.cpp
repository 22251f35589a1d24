// The delta-log writer: a DeltaLog as text, whole or in pieces to a file.
#include <charconv>
#include <string>

#include "delta/atomic_file.hpp"
#include "delta_log_format.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

std::string format_number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

namespace {

// The metadata lines: the required keys first, then every other key in
// the log's order.
void append_metadata(const DeltaLog& log, std::string& out) {
  const auto meta = [&](const std::string& k, const std::string& v) {
    out += "# " + k + " = " + v + "\n";
  };
  meta("format", std::string(kDeltaLogFormat));
  meta("upper_arm_length_m", format_number(log.geometry.upper_arm_length_m));
  meta("forearm_length_m", format_number(log.geometry.forearm_length_m));
  meta("base_radius_m", format_number(log.geometry.base_radius_m));
  meta("platform_radius_m", format_number(log.geometry.platform_radius_m));
  meta("gravity_m_s2", format_number(log.gravity_m_s2));
  if (log.sample_rate_hz) meta("sample_rate_hz", format_number(*log.sample_rate_hz));
  for (const auto& [k, v] : log.metadata) {
    if (k == "format" || k == "upper_arm_length_m" || k == "forearm_length_m" ||
        k == "base_radius_m" || k == "platform_radius_m" || k == "gravity_m_s2" ||
        k == "sample_rate_hz") {
      continue;
    }
    meta(k, v);
  }
}

void append_header(const DeltaLog& log, std::string& out) {
  if (!log.seq.empty()) out += "seq,";
  out += "t,q1,q2,q3,tau1,tau2,tau3";
  if (log.has_qd) out += ",qd1,qd2,qd3";
  if (log.has_qdd) out += ",qdd1,qdd2,qdd3";
  for (const auto& [n, s] : log.extra_columns) out += "," + n;
  out += '\n';
}

// Sample k's line, each number in its shortest round-trip form.
void append_sample(const DeltaLog& log, std::size_t k, std::string& out) {
  char buf[32];
  const auto put = [&](double v) {
    out += ',';
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, r.ptr);
  };
  if (!log.seq.empty()) {
    out += std::to_string(log.seq[k]);
    out += ',';
  }
  const auto r = std::to_chars(buf, buf + sizeof buf, log.t[k]);
  out.append(buf, r.ptr);
  for (unsigned j = 0; j < 3; ++j) put(log.q[j][k]);
  for (unsigned j = 0; j < 3; ++j) put(log.tau[j][k]);
  for (unsigned j = 0; log.has_qd && j < 3; ++j) put(log.qd[j][k]);
  for (unsigned j = 0; log.has_qdd && j < 3; ++j) put(log.qdd[j][k]);
  for (const auto& [n, s] : log.extra_columns) put(s[k]);
  out += '\n';
}

}  // namespace

std::string format_delta_log(const DeltaLog& log) {
  std::string out;
  out.reserve(log.size() * 120 + 512);
  append_metadata(log, out);
  append_header(log, out);
  for (std::size_t k = 0; k < log.size(); ++k) append_sample(log, k, out);
  return out;
}

void write_delta_log_atomically(const std::string& path, const DeltaLog& log) {
  delta::AtomicFileWriter w(path);
  write_delta_log(w, log);
  w.commit();
}

void write_delta_log(delta::AtomicFileWriter& w, const DeltaLog& log) {
  constexpr std::size_t kPiece = 1 << 20;
  std::string text;
  text.reserve(kPiece + 4096);
  append_metadata(log, text);
  append_header(log, text);
  for (std::size_t k = 0; k < log.size(); ++k) {
    append_sample(log, k, text);
    if (text.size() >= kPiece) {
      w.write(text);
      text.clear();
    }
  }
  w.write(text);
}

}  // namespace host_id
