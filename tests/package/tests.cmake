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
set_tests_properties(package.install_and_build_downstream PROPERTIES
  TIMEOUT 900 LABELS package)
