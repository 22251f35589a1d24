#include "recorded_log.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <sstream>

namespace hil {

std::vector<std::uint64_t> recorded_seqs(const std::string& csv) {
  std::ifstream log(csv);
  std::string line;
  while (std::getline(log, line) && !line.empty() && line[0] == '#') {
  }
  std::vector<std::uint64_t> seqs;
  const std::size_t at = line.find("seq");
  if (at == std::string::npos) {
    ADD_FAILURE() << csv << ": no seq column in '" << line << "'";
    return seqs;
  }
  const auto column = static_cast<std::size_t>(
      std::count(line.begin(), line.begin() + static_cast<std::ptrdiff_t>(at), ','));
  while (std::getline(log, line)) {
    std::istringstream fields(line);
    std::string field;
    for (std::size_t k = 0; k <= column; ++k) std::getline(fields, field, ',');
    seqs.push_back(std::stoull(field));
  }
  return seqs;
}

std::uint64_t sum_of_numbers(const std::string& text, const std::string& marker, bool after) {
  std::uint64_t sum = 0;
  const auto is_digit = [](char c) { return c >= '0' && c <= '9'; };
  for (std::size_t at = text.find(marker); at != std::string::npos;
       at = text.find(marker, at + 1)) {
    std::size_t b = after ? at + marker.size() : at;
    std::size_t e = b;
    if (after) {
      while (e < text.size() && is_digit(text[e])) ++e;
    } else {
      while (b > 0 && is_digit(text[b - 1])) --b;
    }
    if (e > b) sum += std::stoull(text.substr(b, e - b));
  }
  return sum;
}

void expect_every_record_accounted_for(const std::string& out, std::uint64_t samples,
                                       std::uint64_t sent, bool killed) {
  const std::uint64_t stale = sum_of_numbers(out, "left out ", true);
  const std::uint64_t cut_off = sum_of_numbers(out, "ended inside ", true);
  EXPECT_LE(cut_off, killed ? 1u : 0u) << out;
  EXPECT_EQ(samples + stale + cut_off, sent) << out;
  EXPECT_EQ(out.find(" lost "), std::string::npos) << out;
  if (stale > 0) std::cout << "note: " << stale << " record(s) marked stale were left out\n";
}

}  // namespace hil
