// The DBC description of the bus, written from the protocol table
// (common/portable/include/delta/can/protocol.hpp), so that standard CAN tools
// (cantools, SavvyCAN, Vector tools) decode the traffic.
#pragma once

#include <string>

namespace host_id {

std::string make_dbc();

}  // namespace host_id
