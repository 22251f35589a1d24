#include "delta/json_text.hpp"

#include <cstddef>

#include "delta/input_error.hpp"

namespace delta {
namespace {

using nlohmann::json;

// A SAX consumer that keeps nothing and remembers where the token the
// parser stopped at begins: the library reports the position of a number
// too large for a double (its out_of_range, not a parse_error) only
// through SAX.
class ErrorPosition final : public nlohmann::json_sax<json> {
 public:
  std::size_t token_start{0};
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t position, const std::string& last_token,
                   const nlohmann::detail::exception&) override {
    // `position` counts the bytes read, the last token's included.
    token_start = position >= last_token.size() ? position - last_token.size() : 0;
    return false;
  }
};

// The library's message without its "[json.exception...] " tag and its own
// "parse error at line L, column C: " (the position is ours, in front).
std::string reason_of(const std::string& what) {
  std::string r = what;
  if (const auto tag_end = r.find("] "); r.rfind("[json.exception", 0) == 0 && tag_end != r.npos) {
    r.erase(0, tag_end + 2);
  }
  if (r.rfind("parse error at line ", 0) == 0) {
    if (const auto colon = r.find(": "); colon != r.npos) r.erase(0, colon + 2);
  }
  return r;
}

// 1-based line and column of a byte of the text.
std::string line_column(std::string_view text, std::size_t byte) {
  const std::size_t end = byte < text.size() ? byte : text.size();
  std::size_t line = 1;
  std::size_t column = 1;
  for (std::size_t i = 0; i < end; ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return std::to_string(line) + ":" + std::to_string(column);
}

}  // namespace

json parse_json(std::string_view text, const std::string& where) {
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    // e.byte counts the bytes read, the offending one included.
    throw InputError(where + ":" + line_column(text, e.byte == 0 ? 0 : e.byte - 1) +
                     ": not valid JSON: " + reason_of(e.what()));
  } catch (const json::exception& e) {
    ErrorPosition position;
    json::sax_parse(text, &position);
    throw InputError(where + ":" + line_column(text, position.token_start) +
                     ": not valid JSON: " + reason_of(e.what()));
  }
}

}  // namespace delta
