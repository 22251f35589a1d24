// The emulator's side of the bus loop: hands it the frames waiting on the
// socket, each stamped with the wall time it is read at, then runs its
// wall-clock checks (heartbeats while no SYNC comes, the consumers'
// supervision once SYNCs stopped, SDO timeouts).
//
// At most `max_frames` per call. In lock-step the next SYNC is often queued
// before the last frame is handled, so the socket may never run dry: with
// one time stamp for a whole batch, a batch that lasted 5 s made every
// frame in it look 5 s old, and the drives faulted on a heartbeat they had
// just received (EMCY 0x8130 in the middle of a run).
#pragma once

#include <cstddef>
#include <cstdint>

#include "emu/emulator.hpp"

namespace emu {

// `receive()` gives the next frame as an optional with `frame` and `error`
// (delta::can::Socket::receive), `now_us()` the wall clock in microseconds.
// Returns how many frames it handed over.
template <class Receive, class Now>
std::size_t pump_frames(Emulator& emulator, Receive&& receive, Now&& now_us,
                        std::size_t max_frames) {
  std::size_t n = 0;
  for (; n < max_frames; ++n) {
    const auto r = receive();
    if (!r) break;
    emulator.set_wall_time(now_us());
    if (!r->error) emulator.on_frame(r->frame);
  }
  emulator.on_wall_time(now_us());
  return n;
}

}  // namespace emu
