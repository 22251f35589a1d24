#include "host_id/options.hpp"

#include <charconv>
#include <cmath>

namespace host_id {

bool wants_help(const std::vector<std::string>& args) {
  for (const auto& a : args) {
    if (a == "--help" || a == "-h") return true;
  }
  return false;
}

ParsedOptions::ParsedOptions(const std::string& command, const std::vector<OptionSpec>& specs,
                             const std::vector<std::string>& args)
    : command_(command) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string a = args[i];
    if (a.size() < 2 || a[0] != '-' || a == "--") {
      positional_.push_back(a);
      continue;
    }
    std::optional<std::string> inline_value;
    if (const auto eq = a.find('='); a.rfind("--", 0) == 0 && eq != std::string::npos) {
      inline_value = a.substr(eq + 1);
      a = a.substr(0, eq);
    }
    const OptionSpec* spec = nullptr;
    for (const auto& s : specs) {
      if (s.name == a || (!s.short_name.empty() && s.short_name == a)) spec = &s;
    }
    if (!spec) {
      throw UsageError(command_ + ": unknown option '" + a + "' (see host_id " + command_ +
                       " --help)");
    }
    if (values_.count(spec->name) && !spec->repeatable) {
      throw UsageError(command_ + ": option " + spec->name + " is given twice");
    }
    auto& slot = values_[spec->name];
    if (!spec->takes_value) {
      if (inline_value) throw UsageError(command_ + ": option " + spec->name + " takes no value");
      slot.emplace_back();
      continue;
    }
    if (inline_value) {
      slot.push_back(*inline_value);
    } else if (i + 1 < args.size()) {
      slot.push_back(args[++i]);
    } else {
      throw UsageError(command_ + ": option " + spec->name + " needs a value");
    }
  }
}

std::optional<std::string> ParsedOptions::value(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end() || it->second.empty()) return std::nullopt;
  return it->second.back();
}

std::vector<std::string> ParsedOptions::values(const std::string& name) const {
  const auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>{} : it->second;
}

double ParsedOptions::number(const std::string& name, double fallback) const {
  const auto v = value(name);
  if (!v) return fallback;
  double d = 0;
  const auto r = std::from_chars(v->data(), v->data() + v->size(), d);
  if (r.ec != std::errc() || r.ptr != v->data() + v->size() || !std::isfinite(d)) {
    throw UsageError(command_ + ": option " + name + " expects a number, got '" + *v + "'");
  }
  return d;
}

std::uint64_t ParsedOptions::whole(const std::string& name, std::uint64_t fallback,
                                   std::uint64_t min, std::uint64_t max) const {
  const auto v = value(name);
  if (!v) return fallback;
  std::uint64_t n = 0;
  const auto r = std::from_chars(v->data(), v->data() + v->size(), n);
  if (r.ec != std::errc() || r.ptr != v->data() + v->size() || n < min || n > max) {
    throw UsageError(command_ + ": option " + name + " expects a whole number from " +
                     std::to_string(min) + " to " + std::to_string(max) + ", got '" + *v + "'");
  }
  return n;
}

std::string ParsedOptions::choice(const std::string& name, const std::string& fallback,
                                  const std::vector<std::string>& allowed) const {
  const auto v = value(name);
  if (!v) return fallback;
  for (const auto& a : allowed) {
    if (a == *v) return a;
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  throw UsageError(command_ + ": option " + name + " must be one of " + list + ", got '" + *v +
                   "'");
}

}  // namespace host_id
