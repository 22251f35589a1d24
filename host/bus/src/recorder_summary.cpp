// What a recording tells its user: its summary as text lines and as JSON,
// and the emergencies seen.
#include <cstdio>
#include <ostream>
#include <sstream>

#include "delta/can/cia402.hpp"
#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "delta/controller/vocabulary.hpp"
#include "host_id/recorder.hpp"

namespace host_id {

namespace p = delta::can::protocol;

std::string describe_emergency(const SeenEmergency& e) {
  char code[48];
  std::snprintf(code, sizeof code, "EMCY 0x%04X", e.code);
  std::ostringstream m;
  if (e.node == p::kControllerNode) {
    m << "the controller (node " << int{e.node} << ") sent " << code;
    if (e.code == delta::can::od::kEmcyErrorReset) {
      m << " (error reset)";
    } else {
      m << ": fault " << e.fault_code << " ("
        << delta::controller::fault_name(static_cast<delta::controller::Fault>(e.fault_code))
        << ")";
    }
  } else {
    m << "node " << int{e.node} << " sent " << code << " (" << delta::can::od::emcy_meaning(e.code)
      << ")";
  }
  std::snprintf(code, sizeof code, "0x%02X", e.error_register);
  m << ", error register " << code;
  if (e.after_log_t_s) {
    m << ", after the log's sample at t = " << *e.after_log_t_s << " s";
  } else {
    m << ", before the log's first sample";
  }
  return m.str();
}

std::string describe_collision(const SeenCollision& c) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "joint %u, residual %.4g, %.4g, %.4g N m against thresholds %.4g, %.4g, %.4g N m",
                c.joint, c.residual_Nm[0], c.residual_Nm[1], c.residual_Nm[2], c.threshold_Nm[0],
                c.threshold_Nm[1], c.threshold_Nm[2]);
  std::ostringstream m;
  m << "the controller detected a collision ";
  if (c.after_log_t_s) {
    m << "after the log's sample at t = " << *c.after_log_t_s << " s";
  } else {
    m << "before the log's first sample";
  }
  m << ": " << buf;
  if (c.joints_seen != 0x7) m << " (some of its frames were lost: those joints read 0)";
  return m.str();
}

void report_emergencies(std::ostream& err, const std::string& who, const RecordSummary& s) {
  for (const SeenEmergency& e : s.emergencies) {
    err << who << ": " << describe_emergency(e) << "\n";
  }
  if (s.collision) err << who << ": " << describe_collision(*s.collision) << "\n";
  if (s.emergencies_not_kept > 0) {
    err << who << ": and " << s.emergencies_not_kept << " more EMCY frame(s)\n";
  }
}

namespace {

nlohmann::json json_collision(const std::optional<SeenCollision>& c) {
  if (!c) return nullptr;
  return {{"joint", c->joint},
          {"after_log_t_s", c->after_log_t_s ? nlohmann::json(*c->after_log_t_s) : nullptr},
          {"residual_Nm", c->residual_Nm},
          {"threshold_Nm", c->threshold_Nm},
          {"whole", c->joints_seen == 0x7}};
}

}  // namespace

nlohmann::json json_summary(const RecordSummary& s) {
  using nlohmann::json;
  const auto runs = [](const std::vector<std::pair<std::uint64_t, std::uint64_t>>& v) {
    json a = json::array();
    for (const auto& [first, count] : v) a.push_back({{"first_seq", first}, {"count", count}});
    return a;
  };
  json emergencies = json::array();
  for (const SeenEmergency& e : s.emergencies) {
    emergencies.push_back({{"node", e.node},
                           {"code", e.code},
                           {"error_register", e.error_register},
                           {"fault_code", e.fault_code},
                           {"after_log_t_s", e.after_log_t_s ? json(*e.after_log_t_s) : json()}});
  }
  return {{"samples", s.samples},
          {"frames", s.frames},
          {"seconds", s.seconds},
          {"lost", s.lost},
          {"gaps", runs(s.gaps)},
          {"stale", s.stale},
          {"stale_runs", runs(s.stale_runs)},
          {"cut_off", {{"first_seq", s.cut_off.first}, {"count", s.cut_off.second}}},
          {"started_inside",
           {{"first_seq", s.started_inside.first}, {"count", s.started_inside.second}}},
          {"socket_drops", s.socket_drops},
          {"currents", s.currents},
          {"arm_encoders", s.arm_encoders},
          {"arm_frames_left_out", s.arm_frames_left_out},
          {"samples_without_currents", s.samples_without_currents},
          {"emergencies", emergencies},
          {"emergencies_not_kept", s.emergencies_not_kept},
          {"collision", json_collision(s.collision)}};
}

void report_left_out(std::ostream& err, const std::string& who, const RecordSummary& s) {
  for (const auto& [first, count] : s.gaps) {
    err << who << ": lost " << count << " sample(s) from seq " << first
        << " (log frames missing)\n";
  }
  for (const auto& [first, count] : s.stale_runs) {
    err << who << ": left out " << count << " sample(s) from seq " << first
        << ": the controller marked them stale (a drive's feedback missed the cycle)\n";
  }
  if (const auto [first, count] = s.started_inside; count > 0) {
    err << who << ": the recording began inside " << count << " sample(s) from seq " << first
        << " (their first log frames came before it listened): not written, no gap in the log\n";
  }
  if (const auto [first, count] = s.cut_off; count > 0) {
    err << who << ": the recording ended inside " << count << " sample(s) from seq " << first
        << " (their log frames were incomplete): not written, no gap in the log\n";
  }
  if (s.arm_frames_left_out > 0) {
    err << who << ": " << s.arm_frames_left_out
        << " LOG_D/LOG_E frames (the arm-side encoders) came after cycles without them and are "
           "not in the log, which has no qa1..qa3: start the recording once the controller "
           "logs them\n";
  }
}

}  // namespace host_id
