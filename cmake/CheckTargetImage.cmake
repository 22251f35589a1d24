# cmake -DIMAGE=elf -DNM=... -DOBJDUMP=... -P CheckTargetImage.cmake
# The Cortex-M image links no heap and no exception machinery, and executes
# no floating-point instruction: no malloc/free/new/delete/__cxa_throw
# symbols, no VFP data-processing instruction in its code.
execute_process(COMMAND ${NM} ${IMAGE} OUTPUT_VARIABLE symbols RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "nm failed on ${IMAGE}")
endif()
set(bad "")
foreach(s malloc free calloc realloc _malloc_r _free_r _Znwj _Znaj _ZdlPv _ZdaPv _ZdlPvj
          __cxa_throw __cxa_allocate_exception __gxx_personality_v0 _Unwind_Resume)
  if(symbols MATCHES "[ \t]${s}\n")
    list(APPEND bad ${s})
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "the image links heap or exception symbols: ${bad}")
endif()
execute_process(COMMAND ${OBJDUMP} -d ${IMAGE} OUTPUT_VARIABLE code RESULT_VARIABLE rc)
string(REGEX MATCHALL "\tv(add|sub|mul|div|mla|mls|fma|fms|neg|abs|sqrt|cvt|cmp|mov|ldr|str|push|pop)[a-z.0-9]*\t[^\n]*" fp "${code}")
if(fp)
  list(LENGTH fp n)
  list(GET fp 0 first)
  message(FATAL_ERROR "${n} floating-point instructions in the image, e.g. ${first}")
endif()
message(STATUS "no heap, no exceptions and no floating point in ${IMAGE}")
