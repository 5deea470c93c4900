# package.bad_call: add_jr_solver() and add_jr_simulator() called wrongly stop
# the configure with a message that names the fix (issue 22 item 5).
# cmake -DJRGEN_SOURCE_DIR=... -DWORK_DIR=... -P this.
foreach(case_and_pattern
    "missing_urdf|TARGET and URDF are required, e.g. add_jr_solver.TARGET robot_dyn URDF robot.urdf"
    "option_without_OPTIONS|unknown arguments: --method;ldlt; the keywords are TARGET, URDF, CUTS, NAMESPACE and OPTIONS"
    "keyword_without_value|no value given for CUTS; give each keyword its value"
    "simulator_missing_urdf|add_jr_simulator: TARGET and URDF are required")
  string(FIND "${case_and_pattern}" "|" bar)
  string(SUBSTRING "${case_and_pattern}" 0 ${bar} case)
  math(EXPR bar "${bar} + 1")
  string(SUBSTRING "${case_and_pattern}" ${bar} -1 pattern)
  file(REMOVE_RECURSE "${WORK_DIR}/${case}")
  execute_process(COMMAND "${CMAKE_COMMAND}" -S "${JRGEN_SOURCE_DIR}/tests/package/bad_call" -B "${WORK_DIR}/${case}"
                          "-DJRGEN_CMAKE_DIR=${JRGEN_SOURCE_DIR}/cmake" "-DCASE=${case}"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc EQUAL 0)
    message(FATAL_ERROR "${case}: the configure succeeded")
  endif()
  string(REGEX REPLACE "[ \n]+" " " flat "${err}")  # CMake wraps long messages
  if(NOT flat MATCHES "${pattern}")
    message(FATAL_ERROR "${case}: the message does not match '${pattern}':\n${err}")
  endif()
endforeach()
