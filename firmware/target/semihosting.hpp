// Output and exit through ARM semihosting (qemu -semihosting-config enable=on).
#pragma once

namespace semihosting {
void write(const char* text);
[[noreturn]] void exit(int code);
}  // namespace semihosting
