// The delta-log format's name, internal to host_id_identification: what
// the reader expects and the writer writes as the first metadata line.
#pragma once

#include <string_view>

namespace host_id {

constexpr std::string_view kDeltaLogFormat = "delta-log/1";

}  // namespace host_id
