# cmake -DSOURCE_DIR=... -P CheckFormat.cmake
# Fails, listing the files, when any C++ source is not clang-formatted.
find_program(CLANG_FORMAT clang-format REQUIRED)
file(GLOB_RECURSE sources
  ${SOURCE_DIR}/common/*.cpp ${SOURCE_DIR}/common/*.hpp
  ${SOURCE_DIR}/host/*.cpp ${SOURCE_DIR}/host/*.hpp
  ${SOURCE_DIR}/firmware/*.cpp ${SOURCE_DIR}/firmware/*.hpp
  ${SOURCE_DIR}/hil/*.cpp ${SOURCE_DIR}/hil/*.hpp
  ${SOURCE_DIR}/tests/*.cpp ${SOURCE_DIR}/tests/*.hpp)
set(bad "")
foreach(f IN LISTS sources)
  execute_process(COMMAND ${CLANG_FORMAT} --dry-run --Werror ${f}
                  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
  if(NOT rc EQUAL 0)
    list(APPEND bad ${f})
  endif()
endforeach()
list(LENGTH sources n)
if(bad)
  list(JOIN bad "\n  " listing)
  message(FATAL_ERROR "not clang-formatted (run clang-format -i on them):\n  ${listing}")
endif()
message(STATUS "all ${n} sources are clang-formatted")
