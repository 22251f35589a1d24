#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace delta {

// Parses JSON text read from `where` (a file name). Anything the parser
// refuses, a syntax error or a number too large for a double
// ("1e400"), becomes an InputError "where:line:column: not valid JSON:
// reason", never an exception of the JSON library.
nlohmann::json parse_json(std::string_view text, const std::string& where);

}  // namespace delta
