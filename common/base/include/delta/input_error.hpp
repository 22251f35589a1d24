// The error vocabulary of everything that reads user input on the host side
// (host_id, the emulator): configuration and input errors are thrown as
// InputError with a message that already says where (file:line:column, key,
// option name); main() prints it on one line and exits non-zero.
#pragma once

#include <stdexcept>

namespace delta {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace delta
