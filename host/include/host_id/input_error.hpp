// The host's error vocabulary: configuration and input errors are thrown as
// InputError with a message that already says where (file:line:column, option
// name); main() prints it on one line and exits non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace host_id {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace host_id
