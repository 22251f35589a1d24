// Exit codes of delta_fw, in one place: main(), the port's loop and the run
// coordinator return them, and docs/firmware.md lists them.
#pragma once

namespace fw_linux {

inline constexpr int kExitDone = 0;
inline constexpr int kExitCanError = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitFault = 3;
inline constexpr int kExitRejected = 4;
inline constexpr int kExitStopped = 5;  // SIGINT/SIGTERM before the runs finished
inline constexpr int kExitIo = 6;       // the Modbus server or the GPIO lines could not start

}  // namespace fw_linux
