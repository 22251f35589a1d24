// Every COB-ID on the bus has one producer: the drives' (their predefined
// connection set and the PDOs their plans use) against each other and
// against the controller's own frames (docs/protocol.md): NMT, SYNC, its
// log, emergency and heartbeat, and its SDO server at node 16.
#include "bus_ids.hpp"

#include <map>
#include <string>

#include "delta/can/protocol.hpp"
#include "drive_planner.hpp"

namespace fw_linux::planning {

namespace p = delta::can::protocol;

namespace {

struct Frame {
  std::uint32_t id;
  std::string what;  // "joint1's TPDO1", "the controller's LOG_A"
  int joint{-1};     // -1: the controller
};

std::vector<Frame> controller_frames() {
  std::vector<Frame> out;
  for (const p::Message& m : p::kMessages) {
    if (m.sender != p::Sender::kController || m.per_node) continue;
    out.push_back({m.base_id, std::string("the controller's ") + m.name, -1});
  }
  out.push_back({0x600u + p::kControllerNode, "the controller's SDO server (request)", -1});
  out.push_back({0x580u + p::kControllerNode, "the controller's SDO server (response)", -1});
  return out;
}

std::vector<Frame> drive_frames(const DrivePlan& plan) {
  const std::string j = "joint" + std::to_string(plan.joint + 1) + "'s ";
  const std::uint32_t n = plan.node;
  std::vector<Frame> out{{0x080u + n, j + "EMCY", static_cast<int>(plan.joint)},
                         {0x580u + n, j + "SDO response", static_cast<int>(plan.joint)},
                         {0x600u + n, j + "SDO request", static_cast<int>(plan.joint)},
                         {0x700u + n, j + "heartbeat", static_cast<int>(plan.joint)}};
  const struct {
    const PlannedPdo& pdo;
    const char* kind;
  } pdos[] = {{plan.rpdo, "RPDO"},
              {plan.sample, "TPDO"},
              {plan.sample_rest, "TPDO"},
              {plan.velocity, "TPDO"},
              {plan.echo, "TPDO"}};
  for (const auto& [pdo, kind] : pdos) {
    if (!pdo.used) continue;
    out.push_back({pdo.cob_id & p::kStandardIdMask, j + kind + std::to_string(pdo.number),
                   static_cast<int>(plan.joint)});
  }
  return out;
}

}  // namespace

void check_bus_ids(const DrivePlans& plans, std::vector<std::string>& problems) {
  std::map<std::uint32_t, Frame> owner;
  for (const Frame& f : controller_frames()) owner.emplace(f.id, f);
  // One problem per drive, naming every frame of it that collides.
  for (const DrivePlan& plan : plans.drives) {
    std::string clashes;
    for (const Frame& f : drive_frames(plan)) {
      const auto [it, fresh] = owner.emplace(f.id, f);
      if (fresh) continue;
      clashes += (clashes.empty() ? "" : "; ") + f.what + " " + hex(f.id, 3) + " is also " +
                 it->second.what;
    }
    if (clashes.empty()) continue;
    const bool controller = plan.node == p::kControllerNode;
    problems.push_back(
        "joint" + std::to_string(plan.joint + 1) + ".node = " + std::to_string(plan.node) +
        ": COB-IDs collide on the bus: " + clashes + "; " +
        (controller ? "node " + std::to_string(p::kControllerNode) +
                          " is the controller's own: give the drive another node (1 to 127)"
                    : "give the drive another node, or its PDOs other COB-IDs") +
        " (docs/protocol.md)");
  }
}

}  // namespace fw_linux::planning
