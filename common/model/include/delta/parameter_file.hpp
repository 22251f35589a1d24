#pragma once

#include <string>

#include "delta/dynamics.hpp"

namespace delta {

// Reads the lumped model's parameters from a JSON file: an object whose keys
// are those of `host_id fit --model delta --per-joint --offsets`
// (arm_inertia_1, ...) or the shared names (arm_inertia, arm_gravity_moment),
// or a saved fit result, whose "parameters" object is taken. Missing keys
// keep the default robot's values. InputError names the file and the key.
LumpedParameters read_lumped_parameters(const std::string& path);

}  // namespace delta
