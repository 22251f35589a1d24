# delta_set_warnings(<target>): the project's strict warning set.
# -Werror is added when DELTA_WERROR is ON (the CI presets turn it on).
function(delta_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wconversion -Wsign-conversion -Wshadow
    -Wdouble-promotion -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Wimplicit-fallthrough)
  if(DELTA_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
