# cmake -DSOURCE_DIR=... -P CheckNoFloat.cmake
# The fixed-point code (common/portable, firmware/core, tests/golden) must not
# use floating point: no float, double, <cmath> or std:: math functions. A
# compile-time conversion (a line with `consteval`) is the one exception.
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
  file(STRINGS ${f} lines)
  set(n 0)
  foreach(l IN LISTS lines)
    math(EXPR n "${n} + 1")
    string(REGEX REPLACE "//.*$" "" code "${l}")
    if(code MATCHES "consteval")
      continue()
    endif()
    if(code MATCHES "(^|[^A-Za-z_])(float|double)([^A-Za-z_]|$)|<cmath>|<math\\.h>|std::(sin|cos|tan|atan|atan2|sqrt|pow|exp|log)[^A-Za-z_]")
      list(APPEND hits "${f}:${n}: ${l}")
    endif()
  endforeach()
endforeach()
list(LENGTH files nfiles)
if(hits)
  list(JOIN hits "\n" listing)
  message(FATAL_ERROR "floating point in fixed-point code:\n${listing}")
endif()
message(STATUS "no floating point in ${nfiles} fixed-point files")
