// The configuration file's keys, internal to delta_fw_config: for each key
// its setter, which parses the value, checks its range and sets it in a
// PortConfig, throwing ConfigError that names the place ("file:line:col")
// and the key.
#pragma once

#include <functional>
#include <map>
#include <string>

#include "fw_linux/config.hpp"

namespace fw_linux {

using ConfigSetter =
    std::function<void(PortConfig& c, const std::string& value, const std::string& where)>;

const std::map<std::string, ConfigSetter>& config_setters();

}  // namespace fw_linux
