# cmake -DCOMMAND="prog;args" -DEXIT=N -DSTREAM=stdout|stderr -DREGEX=re -P ExpectExit.cmake
# Runs COMMAND and fails unless it exits with EXIT and the chosen stream
# matches REGEX: a program's command line (--version, usage errors) as a
# user meets it.
execute_process(COMMAND ${COMMAND} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc
                TIMEOUT 60)
if(STREAM STREQUAL "stderr")
  set(got "${err}")
else()
  set(got "${out}")
endif()
if(NOT rc STREQUAL "${EXIT}")
  message(FATAL_ERROR "'${COMMAND}' exited with '${rc}', expected ${EXIT}\nstdout: ${out}\nstderr: ${err}")
endif()
if(NOT got MATCHES "${REGEX}")
  message(FATAL_ERROR "'${COMMAND}': ${STREAM} does not match '${REGEX}':\n${got}")
endif()
