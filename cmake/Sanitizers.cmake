# With DELTA_SANITIZE=ON every target is built with AddressSanitizer and
# UndefinedBehaviorSanitizer; any report aborts the program, so a test that
# triggers one fails.
if(DELTA_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=all
                      -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()

# With DELTA_FUZZ=ON (clang) every target also gets libFuzzer's coverage
# instrumentation, so that the harnesses in tests/fuzz see into the code
# they call; the harnesses link libFuzzer itself.
if(DELTA_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "DELTA_FUZZ needs clang (the asan and fuzz presets set it)")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
