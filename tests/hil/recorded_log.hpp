// What the HIL pipeline tests read from a recorded delta-log CSV and from
// the recorder's own report of it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hil {

// The `seq` column of a recorded delta-log CSV, row by row.
std::vector<std::uint64_t> recorded_seqs(const std::string& csv);

// The sum of the whole numbers right after (or right before) every
// occurrence of `marker` in `text`; occurrences without a number count 0.
std::uint64_t sum_of_numbers(const std::string& text, const std::string& marker, bool after);

// Records the controller marked stale (a drive's answer came after the
// lock-step timeout, which only a starved machine sees) are left out, not
// lost, and a record the controller was stopped inside (only its first
// frames sent; only `killed` controllers) is cut off: every record sent is
// a sample or one of those.
void expect_every_record_accounted_for(const std::string& out, std::uint64_t samples,
                                       std::uint64_t sent, bool killed = false);

}  // namespace hil
