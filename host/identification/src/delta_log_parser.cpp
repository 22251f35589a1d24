// The delta-log reader: a file's text, a line at a time, into a DeltaLog.
#include <fast_float/fast_float.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <sstream>

#include "delta/input_error.hpp"
#include "delta/read_file.hpp"
#include "delta_log_format.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

namespace {

struct Cursor {
  const std::string& name;
  std::size_t line{0};
  [[noreturn]] void fail(std::size_t column, const std::string& message) const {
    std::ostringstream s;
    s << name << ':' << line << ':' << column << ": " << message;
    throw delta::InputError(s.str());
  }
};

bool is_space(char c) {
  return c == ' ' || c == '\t';
}

std::string_view trim(std::string_view s, std::size_t* leading = nullptr) {
  std::size_t b = 0;
  while (b < s.size() && is_space(s[b])) ++b;
  std::size_t e = s.size();
  while (e > b && is_space(s[e - 1])) --e;
  if (leading) *leading = b;
  return s.substr(b, e - b);
}

bool is_key_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

// Parses a decimal number with at most one sign ('+' allowed, as
// docs/log-format.md says); false if the text is not exactly one number.
bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') {
    s.remove_prefix(1);
    if (!s.empty() && (s.front() == '-' || s.front() == '+')) return false;
  }
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out, std::chars_format::general);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// The 1-based column of the first byte that is not well-formed UTF-8
// (RFC 3629: no overlong forms, no surrogates, nothing above U+10FFFF);
// 0 when every byte is.
std::size_t first_non_utf8_column(std::string_view s) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(s[i]); };
  std::size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = byte(i);
    std::size_t len = 0;
    unsigned char lo = 0x80, hi = 0xBF;  // the second byte's range
    if (c < 0x80) {
      ++i;
      continue;
    } else if (c >= 0xC2 && c <= 0xDF) {
      len = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      len = 3;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      len = 4;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    } else {
      return i + 1;
    }
    if (i + len > s.size() || byte(i + 1) < lo || byte(i + 1) > hi) return i + 1;
    for (std::size_t k = 2; k < len; ++k) {
      if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return i + 1;
    }
    i += len;
  }
  return 0;
}

std::string quoted(std::string_view s) {
  std::string r = "'";
  r.append(s.substr(0, 40));
  if (s.size() > 40) r += "...";
  return r + "'";
}

enum class Role { kT, kQ, kTau, kQd, kQdd, kSeq, kExtra };

struct Column {
  std::string name;
  Role role{Role::kExtra};
  unsigned joint{0};
  Series* target{nullptr};
};

// The reader's state over one file: a line at a time, metadata, then the
// header, then data rows. Each kind of line has its own step.
class LogParser {
 public:
  LogParser(std::string_view text, const std::string& name) : text_(text), cur_{name} {
    log_.name = name;
    if (text_.size() >= 3 && text_.substr(0, 3) == "\xEF\xBB\xBF") text_.remove_prefix(3);  // BOM
  }

  DeltaLog parse() {
    while (pos_ < text_.size()) {
      std::size_t end = text_.find('\n', pos_);
      if (end == std::string_view::npos) end = text_.size();
      std::string_view line = text_.substr(pos_, end - pos_);
      pos_ = end + 1;
      ++cur_.line;
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      if (trim(line).empty()) {
        if (blank_line_ == 0) blank_line_ = cur_.line;
        continue;
      }
      if (blank_line_ != 0) {
        cur_.line = blank_line_;
        cur_.fail(1, "empty line inside the file (only allowed at the end)");
      }
      // Text (metadata, comments, the header) must be UTF-8, as the format
      // says; a data row that is not is refused by its numbers.
      if (!header_seen_ || line.front() == '#') require_utf8(line);
      if (line.front() == '#') {
        if (!header_seen_) metadata_line(line);  // after the header: a comment
      } else if (!header_seen_) {
        header_line(line);
      } else {
        data_row(line);
      }
    }
    return finish();
  }

 private:
  void require_utf8(std::string_view line) {
    if (const std::size_t col = first_non_utf8_column(line)) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", static_cast<unsigned char>(line[col - 1]));
      cur_.fail(col, std::string("not UTF-8 text (byte ") + hex + ")");
    }
  }

  // "# key = value" is metadata; anything else is a comment.
  void metadata_line(std::string_view line) {
    const std::string_view body = line.substr(1);
    const std::size_t eq = body.find('=');
    if (eq == std::string_view::npos) return;
    std::size_t key_lead = 0;
    const std::string_view key = trim(body.substr(0, eq), &key_lead);
    if (key.empty() || !std::all_of(key.begin(), key.end(), is_key_char)) return;
    std::size_t value_lead = 0;
    const std::string_view value = trim(body.substr(eq + 1), &value_lead);
    const std::size_t value_col = 1 + 1 + eq + 1 + value_lead;
    if (value.empty()) cur_.fail(value_col, "metadata key '" + std::string(key) + "' has no value");
    const std::string k(key);
    if (const auto it = key_line_.find(k); it != key_line_.end()) {
      cur_.fail(2 + key_lead, "metadata key '" + k + "' appears twice (first on line " +
                                  std::to_string(it->second) + ")");
    }
    key_line_[k] = cur_.line;
    log_.metadata.emplace_back(k, std::string(value));
    known_metadata(k, value, value_col);
  }

  // The keys the reader uses, checked and stored.
  void known_metadata(const std::string& k, std::string_view value, std::size_t value_col) {
    const auto number = [&](const char* unit) {
      double v = 0.0;
      if (!parse_double(value, v)) {
        cur_.fail(value_col, "metadata key '" + k + "' must be a number in " + unit + ", got " +
                                 quoted(value));
      }
      if (!std::isfinite(v)) cur_.fail(value_col, "metadata key '" + k + "' is not finite");
      return v;
    };
    delta::Geometry& g = log_.geometry;
    if (k == "format") {
      if (value != kDeltaLogFormat) {
        cur_.fail(value_col, "unsupported format " + quoted(value) + "; this reader reads " +
                                 std::string(kDeltaLogFormat));
      }
    } else if (k == "upper_arm_length_m") {
      g.upper_arm_length_m = number("m");
    } else if (k == "forearm_length_m") {
      g.forearm_length_m = number("m");
    } else if (k == "base_radius_m") {
      g.base_radius_m = number("m");
    } else if (k == "platform_radius_m") {
      g.platform_radius_m = number("m");
    } else if (k == "gravity_m_s2") {
      log_.gravity_m_s2 = number("m/s^2");
      if (!(log_.gravity_m_s2 > 0.0)) cur_.fail(value_col, "gravity_m_s2 must be positive");
    } else if (k == "sample_rate_hz") {
      log_.sample_rate_hz = number("Hz");
      if (!(*log_.sample_rate_hz > 0.0)) cur_.fail(value_col, "sample_rate_hz must be positive");
    }
  }

  // The first line that is not metadata: the column names, after the
  // metadata has been checked.
  void header_line(std::string_view line) {
    header_seen_ = true;
    header_line_ = cur_.line;
    check_required_metadata();
    const std::map<std::string, std::size_t> seen = column_names(line);
    const auto has = [&](const std::string& n) { return seen.count(n) > 0; };
    for (const char* required : {"t", "q1", "q2", "q3", "tau1", "tau2", "tau3"}) {
      if (!has(required)) {
        cur_.fail(1, std::string("required column '") + required + "' is missing from the header" +
                         header_hint(line, seen, required));
      }
    }
    for (const char* group : {"qd", "qdd"}) {
      int n = 0;
      for (int j = 1; j <= 3; ++j) n += has(group + std::to_string(j)) ? 1 : 0;
      if (n != 0 && n != 3) {
        cur_.fail(1, std::string("columns ") + group + "1.." + group +
                         "3 must be given all three or none");
      }
    }
    log_.has_qd = has("qd1");
    log_.has_qdd = has("qdd1");
    bind_columns();
    if (log_.sample_rate_hz) nominal_dt_ = 1.0 / *log_.sample_rate_hz;
    reserve_rows();
  }

  // What the header has, and the likely cause where it looks like one:
  // another separator, quoted names, names in another case, a pandas index.
  static std::string header_hint(std::string_view line,
                                 const std::map<std::string, std::size_t>& seen,
                                 const std::string& required) {
    std::vector<std::pair<std::size_t, std::string>> by_column;
    for (const auto& [name, col] : seen) by_column.emplace_back(col, name);
    std::sort(by_column.begin(), by_column.end());
    std::string found;
    for (std::size_t i = 0; i < by_column.size() && i < 8; ++i) {
      found += (i == 0 ? "'" : ", '") + by_column[i].second + "'";
    }
    if (by_column.size() > 8) found += ", ...";
    std::string text = "; it has " + std::to_string(seen.size()) + " column(s): " + found;
    const auto lowered = [](std::string v) {
      for (char& c : v) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      return v;
    };
    if (seen.size() == 1 && (line.find(';') != line.npos || line.find('\t') != line.npos)) {
      return text + " (the names are separated by '" +
             (line.find(';') != line.npos ? std::string(";") : std::string("a tab")) +
             "'; delta-log/1 separates them by ',', docs/log-format.md)";
    }
    for (const auto& [name, col] : seen) {
      const std::string bare = name.size() >= 2 && (name.front() == '"' || name.front() == '\'')
                                   ? name.substr(1, name.size() - 2)
                                   : name;
      if (bare == required) {
        return text + " (the names are quoted; write them bare: t,q1,q2,q3,tau1,tau2,tau3)";
      }
      if (lowered(bare) == required) {
        return text + " ('" + name + "': column names are lower case: '" + required + "')";
      }
    }
    return text + " (docs/log-format.md lists the columns)";
  }

  void check_required_metadata() {
    for (const char* required : {"format", "upper_arm_length_m", "forearm_length_m",
                                 "base_radius_m", "platform_radius_m"}) {
      if (!key_line_.count(required)) {
        cur_.fail(1, std::string("required metadata key '") + required +
                         "' is missing before the header (expected a line '# " + required +
                         " = ...')");
      }
    }
    if (delta::check_geometry(log_.geometry) != delta::GeometryFault::kOk) {
      cur_.line = key_line_["upper_arm_length_m"];
      cur_.fail(
          1, "invalid geometry in the metadata: " + delta::describe_geometry_fault(log_.geometry));
    }
  }

  // The header's names, each with its column number.
  std::map<std::string, std::size_t> column_names(std::string_view line) {
    std::size_t start = 0;
    std::map<std::string, std::size_t> seen;
    while (true) {
      const std::size_t comma = line.find(',', start);
      const std::string_view field =
          line.substr(start, comma == std::string_view::npos ? line.npos : comma - start);
      std::size_t lead = 0;
      const std::string col_name(trim(field, &lead));
      const std::size_t col = start + lead + 1;
      if (col_name.empty()) {
        cur_.fail(col, std::string("empty column name in the header") +
                           (col == 1 ? " (a first column without a name is what pandas writes "
                                       "for its index: write the CSV with index=False)"
                                     : ""));
      }
      if (seen.count(col_name))
        cur_.fail(col, "column '" + col_name + "' appears twice in the header");
      seen[col_name] = col;
      columns_.push_back(Column{col_name});
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    return seen;
  }

  // Each column's role and the series it fills.
  void bind_columns() {
    for (Column& c : columns_) {
      const auto joint_of = [&](std::string_view prefix) -> int {
        if (c.name.size() == prefix.size() + 1 && c.name.compare(0, prefix.size(), prefix) == 0 &&
            c.name.back() >= '1' && c.name.back() <= '3') {
          return c.name.back() - '1';
        }
        return -1;
      };
      const auto bind = [&](Role role, Series* target) {
        c.role = role;
        c.target = target;
      };
      if (c.name == "t") {
        bind(Role::kT, &log_.t);
      } else if (c.name == "seq") {
        bind(Role::kSeq, nullptr);
        has_seq_ = true;
      } else if (const int j = joint_of("q"); j >= 0) {
        bind(Role::kQ, &log_.q[static_cast<unsigned>(j)]);
      } else if (const int j2 = joint_of("tau"); j2 >= 0) {
        bind(Role::kTau, &log_.tau[static_cast<unsigned>(j2)]);
      } else if (const int j3 = joint_of("qd"); j3 >= 0) {
        bind(Role::kQd, &log_.qd[static_cast<unsigned>(j3)]);
      } else if (const int j4 = joint_of("qdd"); j4 >= 0) {
        bind(Role::kQdd, &log_.qdd[static_cast<unsigned>(j4)]);
      } else {
        c.role = Role::kExtra;
        extra_names_.push_back(c.name);
      }
    }
    extra_storage_.resize(extra_names_.size());
    std::size_t e = 0;
    for (Column& c : columns_) {
      if (c.role == Role::kExtra) c.target = &extra_storage_[e++];
    }
  }

  // At most one sample per remaining line: sized once, the columns never
  // move while they fill.
  void reserve_rows() {
    std::size_t rows_left = 1;
    const char* const end = text_.data() + text_.size();
    // After a header on the last line without its '\n', pos_ is one past
    // the end: no rows are left (found by fuzz_delta_log).
    for (const char* p = text_.data() + std::min(pos_, text_.size());
         (p = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p))));
         ++p) {
      ++rows_left;
    }
    for (Column& c : columns_) {
      if (c.target) c.target->reserve(rows_left);
    }
    if (has_seq_) log_.seq.reserve(rows_left);
  }

  void data_row(std::string_view line) {
    if (log_.first_data_line == 0) log_.first_data_line = cur_.line;
    std::size_t start = 0;
    double seq_value = 0.0;
    std::size_t t_col = 1, seq_col = 1;
    for (std::size_t i = 0; i < columns_.size(); ++i) {
      const std::size_t col =
          quick_field(line, i, start) ? last_col_ : careful_field(line, i, start);
      if (columns_[i].role == Role::kSeq) {
        seq_value = last_value_;
        seq_col = col;
      } else {
        columns_[i].target->push_back(last_value_);
      }
      if (columns_[i].role == Role::kT) t_col = col;
    }
    const std::size_t k = log_.t.size() - 1;
    if (has_seq_) check_seq(seq_value, seq_col, k);
    if (k > 0) check_time(t_col, k);
  }

  // The common case: a plain number right up to the comma (or the line's
  // end for the last field), taken by one from_chars into last_value_ (its
  // column in last_col_). Anything else (spaces, a '+', a wrong field
  // count, not a number) is left to careful_field(), which names the
  // problem.
  bool quick_field(std::string_view line, std::size_t i, std::size_t& start) {
    const char* field_end = line.data() + line.size();
    const auto r = fast_float::from_chars(line.data() + start, field_end, last_value_);
    const bool last = i + 1 == columns_.size();
    if (r.ec != std::errc() || r.ptr == line.data() + start || !std::isfinite(last_value_) ||
        !(last ? r.ptr == field_end : (r.ptr != field_end && *r.ptr == ','))) {
      return false;
    }
    last_col_ = start + 1;
    start = static_cast<std::size_t>(r.ptr - line.data()) + 1;
    return true;
  }

  // Field i, starting at start: its value in last_value_; returns its column
  // and moves start past it. Names every breach of the format.
  std::size_t careful_field(std::string_view line, std::size_t i, std::size_t& start) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos && i + 1 < columns_.size()) {
      cur_.fail(line.size() + 1, "row has " + std::to_string(i + 1) + " fields, the header has " +
                                     std::to_string(columns_.size()));
    }
    if (comma != std::string_view::npos && i + 1 == columns_.size()) {
      std::size_t fields = columns_.size();
      for (std::size_t p = comma; p != std::string_view::npos; p = line.find(',', p + 1)) ++fields;
      cur_.fail(comma + 1, "row has " + std::to_string(fields) + " fields, the header has " +
                               std::to_string(columns_.size()));
    }
    const std::string_view raw =
        line.substr(start, comma == std::string_view::npos ? line.npos : comma - start);
    std::size_t lead = 0;
    const std::string_view field = trim(raw, &lead);
    const std::size_t col = start + lead + 1;
    if (!parse_double(field, last_value_)) {
      cur_.fail(
          col, "column '" + columns_[i].name + "': " +
                   (field.empty() ? std::string("empty field") : "not a number: " + quoted(field)));
    }
    if (!std::isfinite(last_value_))
      cur_.fail(col, "column '" + columns_[i].name + "': NaN or Inf is not allowed");
    start = comma + 1;
    return col;
  }

  void check_seq(double seq_value, std::size_t seq_col, std::size_t k) {
    if (seq_value < 0.0 || seq_value != std::floor(seq_value) || seq_value > 9.007199254740992e15) {
      cur_.fail(seq_col, "column 'seq': must be a non-negative whole number");
    }
    const auto s = static_cast<std::uint64_t>(seq_value);
    if (!log_.seq.empty()) {
      const std::uint64_t prev = log_.seq.back();
      if (s <= prev) {
        cur_.fail(seq_col, "column 'seq': " + std::to_string(s) + " does not increase (previous " +
                               std::to_string(prev) + ")");
      }
      if (s != prev + 1) {
        log_.gaps.push_back({k, cur_.line,
                             "seq jumps from " + std::to_string(prev) + " to " + std::to_string(s) +
                                 " (" + std::to_string(s - prev - 1) + " samples lost)"});
      }
    }
    log_.seq.push_back(s);
  }

  void check_time(std::size_t t_col, std::size_t k) {
    const double dt = log_.t[k] - log_.t[k - 1];
    if (!(dt > 0.0)) {
      cur_.fail(t_col, "column 't': time " + format_number(log_.t[k]) +
                           " s is not after the previous sample's " + format_number(log_.t[k - 1]) +
                           " s");
    }
    if (nominal_dt_ == 0.0) nominal_dt_ = dt;  // no sample_rate_hz: the first step
    const bool already = !log_.gaps.empty() && log_.gaps.back().index == k;
    if (dt > 1.5 * nominal_dt_ && !already) {
      std::ostringstream w;
      w << "time jumps by " << dt << " s from " << log_.t[k - 1] << " s, "
        << "more than 1.5 sample periods (" << nominal_dt_ << " s)";
      log_.gaps.push_back({k, cur_.line, w.str()});
      ++time_gaps_;
    }
  }

  // A declared sample rate that most time steps contradict is wrong, not
  // a log full of gaps: refused at its metadata line, with the rate the
  // time column shows.
  void check_declared_rate() {
    const std::size_t steps = log_.t.size() - 1;
    if (!log_.sample_rate_hz || steps < 4 || 2 * time_gaps_ <= steps) return;
    std::vector<double> dt(steps);
    for (std::size_t k = 0; k < steps; ++k) dt[k] = log_.t[k + 1] - log_.t[k];
    std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(steps / 2), dt.end());
    const double median = dt[steps / 2];
    std::ostringstream m;
    m << "sample_rate_hz = " << *log_.sample_rate_hz << " declares a step of " << nominal_dt_
      << " s, but " << time_gaps_ << " of the " << steps
      << " time steps are longer than 1.5 of it (the median step is " << median << " s, "
      << 1.0 / median << " Hz): ";
    const std::string ms = milliseconds_hint(median, log_.sample_rate_hz);
    m << (ms.empty() ? "correct sample_rate_hz or remove it" : ms);
    cur_.line = key_line_["sample_rate_hz"];
    cur_.fail(1, m.str());
  }

  DeltaLog finish() {
    if (!header_seen_) {
      cur_.line = std::max<std::size_t>(cur_.line, 1);
      cur_.fail(1, "no header row: the file has no line of column names");
    }
    if (log_.t.empty()) {
      cur_.line = header_line_;
      cur_.fail(1, "no data rows after the header");
    }
    check_declared_rate();
    for (std::size_t i = 0; i < extra_names_.size(); ++i) {
      log_.extra_columns.emplace_back(extra_names_[i], std::move(extra_storage_[i]));
    }
    return std::move(log_);
  }

  std::string_view text_;
  Cursor cur_;
  DeltaLog log_;
  std::size_t pos_{0};
  std::map<std::string, std::size_t> key_line_;
  std::vector<Column> columns_;
  std::vector<Series> extra_storage_;
  std::vector<std::string> extra_names_;
  bool header_seen_{false};
  std::size_t header_line_{0};
  double nominal_dt_{0.0};
  std::size_t time_gaps_{0};   // gaps found by time (not by seq)
  std::size_t blank_line_{0};  // first blank line seen, only allowed at the end
  bool has_seq_{false};        // the header names a seq column
  double last_value_{0.0};     // of the field just read
  std::size_t last_col_{0};    // its column, from quick_field()
};

}  // namespace

DeltaLog parse_delta_log(std::string_view text, const std::string& name) {
  return LogParser(text, name).parse();
}

DeltaLog read_delta_log(const std::string& path) {
  return parse_delta_log(delta::read_file_bytes(path).view(), path);
}

}  // namespace host_id
