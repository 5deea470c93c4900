# jrgen_discover_suites(<target> [TEST_PREFIX prefix] [TEST_FILTER -negative:patterns])
#
# Adds one ctest test per GoogleTest test suite of <target> (every test of
# "Suite.*", or of "Instance/Suite.*" for a parameterized suite), found after
# the build by running <target> --gtest_list_tests, as gtest_discover_tests()
# does for single tests.  One process per suite instead of one per test: a
# test process costs 0.08-0.4 CPU-s to start (loading a 36 MB program, building
# the model cases), more than most tests themselves, and the suite had about
# 2600 of them (docs/testing.md, "CI time").  To run one test:
#   build/tests/<program> --gtest_filter=Suite.Test
# A suite in which a test was skipped and none failed exits with 77 (the
# project's main(), tests/common/gtest_main.cpp) and ctest reports it skipped.
set(_JRGEN_DISCOVER_SCRIPT "${CMAKE_CURRENT_LIST_DIR}/discover_suites_script.cmake")
function(jrgen_discover_suites target)
  cmake_parse_arguments(DS "" "TEST_PREFIX;TEST_FILTER" "" ${ARGN})
  if(DS_TEST_FILTER AND NOT DS_TEST_FILTER MATCHES "^-")
    message(FATAL_ERROR "jrgen_discover_suites(${target}): TEST_FILTER takes only negative patterns (-A.*:B.*)")
  endif()
  set(_tests "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake")
  set(_include "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites_include.cmake")
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND "${CMAKE_COMMAND}" "-DEXE=$<TARGET_FILE:${target}>" "-DOUT=${_tests}"
            "-DPREFIX=${DS_TEST_PREFIX}" "-DFILTER=${DS_TEST_FILTER}"
            "-DWORKDIR=${CMAKE_CURRENT_BINARY_DIR}" -P "${_JRGEN_DISCOVER_SCRIPT}"
    BYPRODUCTS "${_tests}"
    VERBATIM)
  file(WRITE "${_include}"
    "if(EXISTS \"${_tests}\")\n  include(\"${_tests}\")\n"
    "else()\n  add_test(${target}_NOT_BUILT ${target}_NOT_BUILT)\nendif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${_include}")
endfunction()
