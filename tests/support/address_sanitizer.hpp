// DELTA_ADDRESS_SANITIZER: 1 where AddressSanitizer replaces malloc and
// operator new (GCC defines __SANITIZE_ADDRESS__, Clang has the feature),
// else 0. For tests of what only glibc's malloc or a plain address space
// shows.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define DELTA_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define DELTA_ADDRESS_SANITIZER 1
#endif
#endif
#ifndef DELTA_ADDRESS_SANITIZER
#define DELTA_ADDRESS_SANITIZER 0
#endif
