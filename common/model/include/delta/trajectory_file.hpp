// The trajectory file, delta-trajectory/1 (docs/trajectory-file.md): a
// Fourier excitation as the controller runs it, written by `host_id design`
// and read by `host_id simulate --trajectory-file`, `host_id excite
// --trajectory-file` and delta_fw.
#pragma once

#include <string>

#include "delta/trajectory.hpp"

namespace delta {

// Reads and checks a trajectory file. InputError names the file and the key:
// a missing or unknown key, a wrong type, a value out of range, harmonics
// that differ between the joints or exceed 6.
BlendedFourierTrajectory read_trajectory_file(const std::string& path);
// The same from text; `where` names it in messages.
BlendedFourierTrajectory parse_trajectory(const std::string& text, const std::string& where);

// The file's text. `design_json` (a JSON object, or empty) is stored under
// "design" as it is: what made the trajectory, for the reader's information.
std::string format_trajectory(const BlendedFourierTrajectory& t, const std::string& design_json);

}  // namespace delta
