# cmake -DEXE=<program> -DOUT=<file> [-DPREFIX=p] [-DFILTER=-A.*:B.*] -DWORKDIR=<dir> -P discover_suites_script.cmake
# Writes OUT: one add_test() per test suite that EXE lists (tests/common/discover_suites.cmake).
execute_process(COMMAND "${EXE}" --gtest_list_tests "--gtest_filter=*${FILTER}"
                OUTPUT_VARIABLE listing ERROR_VARIABLE errors RESULT_VARIABLE rc TIMEOUT 60)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${EXE} --gtest_list_tests failed (${rc}):\n${listing}${errors}")
endif()
string(REPLACE "\n" ";" lines "${listing}")
set(text "# Written by tests/common/discover_suites_script.cmake from ${EXE} --gtest_list_tests; do not edit.\n")
set(count 0)
foreach(line IN LISTS lines)
  # A suite line starts in column 0 and ends with '.' (a typed suite adds "  # TypeParam = ...").
  if(line MATCHES "^([^ #][^ ]*)\\.( .*)?$")
    set(suite "${CMAKE_MATCH_1}")
    if(suite MATCHES "\\]=\\]|^Running main")
      message(FATAL_ERROR "${EXE}: cannot name a ctest test after the suite '${suite}'")
    endif()
    string(APPEND text
      "add_test([=[${PREFIX}${suite}]=] \"${EXE}\" [=[--gtest_filter=${suite}.*${FILTER}]=])\n"
      "set_tests_properties([=[${PREFIX}${suite}]=] PROPERTIES WORKING_DIRECTORY \"${WORKDIR}\" TIMEOUT 600\n"
      "  SKIP_RETURN_CODE 77 ENVIRONMENT JRGEN_TEST_SKIP_CODE=77)\n")
    math(EXPR count "${count} + 1")
  endif()
endforeach()
if(count EQUAL 0)
  message(FATAL_ERROR "${EXE} lists no test suite:\n${listing}")
endif()
file(WRITE "${OUT}" "${text}")
