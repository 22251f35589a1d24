# cmake -DSOURCE_DIR=... -P CheckNoFloat.cmake
# The fixed-point code (common/portable, firmware/core, tests/golden) must not
# use floating point: no float, double, <cmath> or std:: math functions. A
# compile-time conversion (a line with `consteval`, and the body of a
# consteval function) is the one exception.
# What these targets may include is enforced by the build (each part of
# common/ has its own include folder) and the Cortex-M build compiles them
# with -mgeneral-regs-only; this check also covers headers that no Cortex-M
# source includes, and builds without the Cortex-M image (the sanitizer build).
file(GLOB_RECURSE files
  ${SOURCE_DIR}/common/portable/*.hpp ${SOURCE_DIR}/common/portable/*.cpp
  ${SOURCE_DIR}/firmware/core/*.hpp ${SOURCE_DIR}/firmware/core/*.cpp
  ${SOURCE_DIR}/tests/golden/*.hpp ${SOURCE_DIR}/tests/golden/*.cpp)
set(hits "")
foreach(f IN LISTS files)
  # One list element per line: file(STRINGS) merged the lines between an
  # unbalanced "[" and its "]" (a comment's "[-2, 2)") into one element, and
  # one "consteval" in it exempted them all.
  file(READ ${f} content)
  string(REPLACE ";" "<semicolon>" content "${content}")
  string(REPLACE "[" "<lbracket>" content "${content}")
  string(REPLACE "]" "<rbracket>" content "${content}")
  string(REPLACE "\\" "/" content "${content}")
  string(REPLACE "\n" ";" lines "${content}")
  set(n 0)
  set(exempt_depth 0)  # > 0: inside a consteval function's body
  foreach(l IN LISTS lines)
    math(EXPR n "${n} + 1")
    string(REGEX REPLACE "//.*$" "" code "${l}")
    string(REGEX MATCHALL "{" opens "${code}")
    string(REGEX MATCHALL "}" closes "${code}")
    list(LENGTH opens n_open)
    list(LENGTH closes n_close)
    if(exempt_depth GREATER 0)
      math(EXPR exempt_depth "${exempt_depth} + ${n_open} - ${n_close}")
      continue()
    endif()
    if(code MATCHES "consteval")
      math(EXPR exempt_depth "${n_open} - ${n_close}")
      continue()
    endif()
    if(code MATCHES "(^|[^A-Za-z_])(float|double)([^A-Za-z_]|$)|<cmath>|<math\\.h>|std::(sin|cos|tan|atan|atan2|sqrt|pow|exp|log)[^A-Za-z_]")
      string(REPLACE "<semicolon>" ";" shown "${l}")
      string(REPLACE "<lbracket>" "[" shown "${shown}")
      string(REPLACE "<rbracket>" "]" shown "${shown}")
      string(APPEND hits "${f}:${n}: ${shown}\n")
    endif()
  endforeach()
endforeach()
list(LENGTH files nfiles)
if(hits)
  # Each hit on a line of its own (FATAL_ERROR would wrap them at spaces).
  message(NOTICE "${hits}")
  message(FATAL_ERROR "floating point in fixed-point code (the lines above)")
endif()
message(STATUS "no floating point in ${nfiles} fixed-point files")
