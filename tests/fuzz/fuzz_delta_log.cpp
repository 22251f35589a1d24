// libFuzzer harness: the delta-log/1 reader. Any input either is refused
// with delta::InputError, or is accepted and then must honour the format's
// contract (docs/log-format.md): every required column of one length, every
// value finite, t strictly increasing, seq increasing, a valid geometry.
// A breach aborts, which libFuzzer reports as a crash.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "delta/input_error.hpp"
#include "host_id/delta_log.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

void check_contract(const host_id::DeltaLog& log) {
  const std::size_t n = log.size();
  require(n > 0);
  require(delta::check_geometry(log.geometry) == delta::GeometryFault::kOk);
  for (unsigned j = 0; j < 3; ++j) {
    require(log.q[j].size() == n && log.tau[j].size() == n);
    require(!log.has_qd || log.qd[j].size() == n);
    require(!log.has_qdd || log.qdd[j].size() == n);
    for (std::size_t k = 0; k < n; ++k)
      require(std::isfinite(log.q[j][k]) && std::isfinite(log.tau[j][k]));
  }
  for (std::size_t k = 0; k < n; ++k) require(std::isfinite(log.t[k]));
  for (std::size_t k = 1; k < n; ++k) require(log.t[k] > log.t[k - 1]);
  require(log.seq.empty() || log.seq.size() == n);
  for (std::size_t k = 1; k < log.seq.size(); ++k) require(log.seq[k] > log.seq[k - 1]);
  for (const auto& [name, series] : log.extra_columns) require(series.size() == n);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    check_contract(host_id::parse_delta_log(text, "fuzz.csv"));
  } catch (const delta::InputError&) {
    // refused, with a message: fine
  }
  return 0;
}
