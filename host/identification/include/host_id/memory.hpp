// How host_id asks malloc to treat the fit's large blocks.
#pragma once

namespace host_id {

// Makes malloc keep the blocks it is given back (up to 32 MiB each, and up
// to 256 MiB at the top of its heap) for the next ones, instead of returning
// each to the kernel and taking fresh pages, which the kernel must fault in
// and clear. A fit frees the file's text and the log's columns just before
// it allocates the regressor, and the kernel's clearing was a tenth of its
// CPU time. All threads take their blocks from that one heap (one arena),
// so that a pass on a worker thread reuses what the main thread freed
// rather than growing a heap of its own. Called once, first thing, by
// programs that read logs; a no-op where the C library has no such knobs.
void keep_freed_memory_for_reuse();

}  // namespace host_id
