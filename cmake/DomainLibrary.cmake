# delta_domain_library(PREFIX NAME SOURCES ...): a static library
# delta_<PREFIX>_<NAME> (alias delta::<PREFIX>_<NAME>) of one domain folder,
# NAME/, whose public headers are in NAME/include: host/ and firmware/linux/
# are made of these, so that the build refuses an include across a missing
# link.
function(delta_domain_library prefix name)
  cmake_parse_arguments(ARG "" "" "SOURCES" ${ARGN})
  add_library(delta_${prefix}_${name} STATIC ${ARG_SOURCES})
  add_library(delta::${prefix}_${name} ALIAS delta_${prefix}_${name})
  target_include_directories(delta_${prefix}_${name}
                             PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/${name}/include)
  delta_set_warnings(delta_${prefix}_${name})
endfunction()
