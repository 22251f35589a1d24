// A small, strict command-line option parser: every option is declared, an
// unknown one or a malformed value is a UsageError that names it.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "delta/input_error.hpp"

namespace host_id {

class UsageError : public delta::InputError {
 public:
  using delta::InputError::InputError;
};

struct OptionSpec {
  OptionSpec(std::string n, bool takes = true, bool repeat = false, std::string short_n = {})
      : name(std::move(n)),
        takes_value(takes),
        repeatable(repeat),
        short_name(std::move(short_n)) {}
  std::string name;  // "--seed"
  bool takes_value;
  bool repeatable;
  std::string short_name;  // "-o", optional
};

// Whether a command's arguments ask for its help (--help or -h).
bool wants_help(const std::vector<std::string>& args);

class ParsedOptions {
 public:
  ParsedOptions(const std::string& command, const std::vector<OptionSpec>& specs,
                const std::vector<std::string>& args);

  bool flag(const std::string& name) const { return values_.count(name) > 0; }
  std::optional<std::string> value(const std::string& name) const;
  std::vector<std::string> values(const std::string& name) const;
  const std::vector<std::string>& positional() const { return positional_; }

  double number(const std::string& name, double fallback) const;
  std::uint64_t whole(const std::string& name, std::uint64_t fallback, std::uint64_t min,
                      std::uint64_t max) const;
  std::string choice(const std::string& name, const std::string& fallback,
                     const std::vector<std::string>& allowed) const;

 private:
  std::string command_;
  std::map<std::string, std::vector<std::string>> values_;
  std::vector<std::string> positional_;
};

}  // namespace host_id
