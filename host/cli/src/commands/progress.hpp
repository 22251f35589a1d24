// A one-line progress bar on stderr, for what can take more than a couple
// of seconds: shown only on a terminal and without --quiet, so that logs
// and pipes get no carriage returns.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>

namespace host_id {

class ProgressBar {
 public:
  ProgressBar(const char* label, bool quiet)
      : label_(label), enabled_(!quiet && isatty(STDERR_FILENO) != 0) {}
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  ~ProgressBar() { finish(); }

  bool enabled() const { return enabled_; }
  // "LABEL [#####      ]  done/total  detail".
  void show(std::size_t done, std::size_t total, const std::string& detail = "") {
    if (!enabled_) return;
    const int width = 40;
    const int filled = total ? static_cast<int>(static_cast<double>(width) *
                                                static_cast<double>(std::min(done, total)) /
                                                static_cast<double>(total))
                             : width;
    std::fprintf(stderr, "\r%s [%-*s] %zu/%zu  %s", label_, width,
                 std::string(static_cast<std::size_t>(filled), '#').c_str(), done, total,
                 detail.c_str());
    std::fflush(stderr);
    shown_ = true;
  }
  // Clears the line.
  void finish() {
    if (shown_) std::fprintf(stderr, "\r%*s\r", 100, "");
    shown_ = false;
  }

 private:
  const char* label_;
  bool enabled_;
  bool shown_{false};
};

}  // namespace host_id
