# package.install_and_build_downstream: installs this build into a scratch
# prefix, builds examples/downstream (and tests/package/solver_project)
# against it through find_package(jrgen) and add_jr_solver(), runs them, and
# checks that touching the URDF, the cuts file or the installed jrgen makes the
# next build regenerate the solver.  Runs as a CMake script (no network).
# Included from tests/CMakeLists.txt.
add_test(NAME package.install_and_build_downstream
  COMMAND "${CMAKE_COMMAND}"
    "-DJRGEN_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
    "-DJRGEN_BINARY_DIR=${PROJECT_BINARY_DIR}"
    "-DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/package_test"
    "-DCONFIG=$<CONFIG>"
    "-DGENERATOR=${CMAKE_GENERATOR}"
    "-DMAKE_PROGRAM=${CMAKE_MAKE_PROGRAM}"
    "-DCXX_COMPILER=${CMAKE_CXX_COMPILER}"
    "-DEIGEN3_DIR=${Eigen3_DIR}"
    "-DBINDIR=${CMAKE_INSTALL_BINDIR}"
    "-DLIBDIR=${CMAKE_INSTALL_LIBDIR}"
    "-DINCLUDEDIR=${CMAKE_INSTALL_INCLUDEDIR}"
    -P "${CMAKE_CURRENT_LIST_DIR}/install_and_build_downstream.cmake")
# COST: the longest tests of the suite (40-80 s, each building a project, the
# FetchContent one with -j2), so ctest -j starts them first and the many short
# tests fill the cores around them, instead of the two running alone at the
# end (docs/testing.md).
set_tests_properties(package.install_and_build_downstream PROPERTIES
  TIMEOUT 900 LABELS package COST 1000)

# jrgen pulled into a project's own build (tests/package/subproject), with
# FetchContent and with add_subdirectory(): each built and run, its output
# checked (Debug without -g: the quickest full compile of jrgen).  The
# generator is compiled once, by the add_subdirectory build; the FetchContent
# build (FetchContent_MakeAvailable() is add_subdirectory() of the populated
# source: the same compiles) generates with this build's jrgen through the
# JRGEN_GENERATOR option and compiles the runtime, the solver and the program
# (docs/testing.md, "CI time": -130 CPU-s).
foreach(_mode fetchcontent subdirectory)
  set(_build ON)
  set(_program "")
  if(_mode STREQUAL "fetchcontent")
    set(_program "-DJRGEN_PROGRAM=$<TARGET_FILE:jrgen>")
  endif()
  add_test(NAME package.subproject_${_mode}
    COMMAND "${CMAKE_COMMAND}"
      "-DJRGEN_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
      "-DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/subproject_test"
      "-DMODE=${_mode}" "-DBUILD=${_build}"
      "-DGENERATOR=${CMAKE_GENERATOR}"
      "-DMAKE_PROGRAM=${CMAKE_MAKE_PROGRAM}"
      "-DCXX_COMPILER=${CMAKE_CXX_COMPILER}"
      "-DEIGEN3_DIR=${Eigen3_DIR}"
      "-DLAUNCHER=${CMAKE_CXX_COMPILER_LAUNCHER}"
      ${_program}
      -P "${CMAKE_CURRENT_LIST_DIR}/subproject_test.cmake")
  set_tests_properties(package.subproject_${_mode} PROPERTIES TIMEOUT 900 LABELS package)
  set_tests_properties(package.subproject_${_mode} PROPERTIES COST 2000)  # first (see above)
endforeach()

# The README's demo (examples/demo), run and its output checked: sizes against
# the URDF, errors against its dense reference (tests/package/check_demo.cmake).
if(TARGET jrgen_demo)
  add_test(NAME examples.demo
           COMMAND "${CMAKE_COMMAND}" "-DDEMO=$<TARGET_FILE:jrgen_demo>" "-DURDF=${JRGEN_DEMO_MODEL}"
                   -P "${CMAKE_CURRENT_LIST_DIR}/check_demo.cmake")
else()
  add_test(NAME examples.demo COMMAND "${CMAKE_COMMAND}" -E echo "examples/demo not built (JRGEN_BUILD_DEMO=OFF)")
  set_tests_properties(examples.demo PROPERTIES SKIP_REGULAR_EXPRESSION "not built")
endif()

# add_jr_solver() / add_jr_simulator() called wrongly: the configure stops with
# a message naming the fix (tests/package/bad_call.cmake).
add_test(NAME package.bad_call
  COMMAND "${CMAKE_COMMAND}" "-DJRGEN_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
          "-DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/bad_call_test" -P "${CMAKE_CURRENT_LIST_DIR}/bad_call.cmake")
set_tests_properties(package.bad_call PROPERTIES TIMEOUT 120 LABELS package)
