# Whether the test suite's dependencies are installed (scripts/install_dependencies.sh
# without --demo).  After `install_dependencies.sh --demo` they are not, and the
# README's first command still configures the whole project to build the demo:
# the tests are then left out with a warning, and ctest fails on a single test
# that names the missing packages instead of passing with no tests.
set(JRGEN_TEST_DEPENDENCIES_MISSING "")
find_package(GTest QUIET)
if(NOT GTest_FOUND)
  list(APPEND JRGEN_TEST_DEPENDENCIES_MISSING "GoogleTest (libgtest-dev)")
endif()
find_package(benchmark QUIET)
if(NOT benchmark_FOUND)
  list(APPEND JRGEN_TEST_DEPENDENCIES_MISSING "Google Benchmark (libbenchmark-dev)")
endif()
foreach(_lib mujoco:libmujoco-dev umfpack:libsuitesparse-dev lapacke:liblapacke-dev)
  string(REPLACE ":" ";" _lib "${_lib}")
  list(GET _lib 0 _name)
  list(GET _lib 1 _package)
  string(TOUPPER "${_name}" _upper)
  find_library(JRGEN_${_upper}_LIBRARY ${_name})
  if(NOT JRGEN_${_upper}_LIBRARY)
    list(APPEND JRGEN_TEST_DEPENDENCIES_MISSING "${_name} (${_package})")
  endif()
endforeach()
# SUNDIALS CVODE: the independent reference trajectories (tests/reference/trajectories.cmake).
find_package(SUNDIALS QUIET CONFIG)
if(NOT SUNDIALS_FOUND)
  list(APPEND JRGEN_TEST_DEPENDENCIES_MISSING "SUNDIALS (libsundials-dev)")
endif()
find_package(Python3 QUIET COMPONENTS Interpreter)
if(NOT Python3_Interpreter_FOUND)
  list(APPEND JRGEN_TEST_DEPENDENCIES_MISSING "Python 3 (python3)")
endif()

if(JRGEN_TEST_DEPENDENCIES_MISSING)
  string(JOIN ", " _missing ${JRGEN_TEST_DEPENDENCIES_MISSING})
  message(WARNING "jrgen: the test suite is left out: missing ${_missing}. "
                  "Run scripts/install_dependencies.sh (without --demo) for the tests.")
  add_test(NAME test_dependencies_missing
           COMMAND sh -c "echo 'jrgen: the tests were not built: missing ${_missing}; run scripts/install_dependencies.sh and configure again' >&2; exit 1")
endif()
