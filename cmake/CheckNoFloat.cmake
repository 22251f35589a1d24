# cmake -DSOURCE_DIR=... -P CheckNoFloat.cmake
# The fixed-point code paths (firmware/core, common/*/fixed) must not use
# floating point: no float, double, <cmath> or std:: math functions. A
# compile-time conversion (a line with `consteval`) is the one exception.
file(GLOB_RECURSE files
  ${SOURCE_DIR}/firmware/core/*.hpp ${SOURCE_DIR}/firmware/core/*.cpp
  ${SOURCE_DIR}/firmware/golden/*.hpp ${SOURCE_DIR}/firmware/golden/*.cpp
  ${SOURCE_DIR}/common/include/delta/fixed/*.hpp ${SOURCE_DIR}/common/src/fixed/*.cpp
  ${SOURCE_DIR}/common/include/delta/can/protocol.hpp ${SOURCE_DIR}/common/include/delta/can/cia402.hpp)
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
