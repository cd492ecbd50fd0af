# Runs eomgen-mjcf on a file it must refuse, over a stale header: it must fail with one line
# matching EXPECTED and leave no header behind.
file(WRITE "${OUTPUT}" "// stale\n")
execute_process(COMMAND "${TOOL}" "${INPUT}" -o "${OUTPUT}" RESULT_VARIABLE code
                OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(code EQUAL 0)
  message(FATAL_ERROR "eomgen-mjcf accepted ${INPUT}")
endif()
if(NOT err MATCHES "${EXPECTED}")
  message(FATAL_ERROR "eomgen-mjcf's message \"${err}\" does not match \"${EXPECTED}\"")
endif()
if(EXISTS "${OUTPUT}" OR EXISTS "${OUTPUT}.tmp")
  message(FATAL_ERROR "eomgen-mjcf left ${OUTPUT} behind")
endif()
message(STATUS "refused as expected: ${err}")
