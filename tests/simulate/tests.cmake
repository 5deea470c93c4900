# ---- time integration (runtime/include/jrgen/simulate.hpp, docs/simulation.md) ----
jrgen_test(simulate_ode_test simulate/ode_test.cpp)
target_link_libraries(simulate_ode_test PRIVATE jrgen_runtime)

# Generated solvers of the mechanism tests; with JRGEN_TEST_SUBSET (the
# sanitizer build) only when the subset keeps the four-bar they also need.
if(NOT JRGEN_TEST_SUBSET OR "gen_loops_fourbar_conservative" IN_LIST JRGEN_TEST_SUBSET)
  add_jr_solver(TARGET sim_double_pendulum URDF ${PROJECT_SOURCE_DIR}/tests/cli/double_pendulum.urdf NAMESPACE sim_dp)
  add_jr_solver(TARGET sim_stiff_damped URDF ${CMAKE_CURRENT_SOURCE_DIR}/simulate/stiff_damped_pendulum.urdf
                NAMESPACE sim_sd)
  add_jr_solver(TARGET sim_stiff_spring URDF ${CMAKE_CURRENT_SOURCE_DIR}/simulate/stiff_spring_pendulum.urdf
                NAMESPACE sim_ss)
  add_jr_solver(TARGET sim_ball_floating URDF ${CMAKE_CURRENT_SOURCE_DIR}/simulate/ball_floating.urdf NAMESPACE sim_bf)
  jrgen_test(simulate_mechanism_test simulate/mechanism_test.cpp)
  target_link_libraries(simulate_mechanism_test PRIVATE jrgen_model_cases jrgen_urdf
                        sim_double_pendulum sim_stiff_damped sim_stiff_spring sim_ball_floating gen_loops_fourbar_conservative)
endif()

# The simulator executable of add_jr_simulator() (docs/interface.md section 7):
# CSV header, rows, last stdout line, errors (check_simulator.cmake).
add_jr_simulator(TARGET fourbar_sim URDF ${PROJECT_SOURCE_DIR}/models/fourbar.urdf NAMESPACE fourbar_sim)
add_test(NAME simulate_cli_test
         COMMAND ${CMAKE_COMMAND} -DSIM=$<TARGET_FILE:fourbar_sim> -DWORK=${CMAKE_CURRENT_BINARY_DIR}/simulate_cli
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/simulate/check_simulator.cmake)

# Extreme cases in time (issue 21 item 4; docs/simulation.md "Extreme cases in
# time"): mass ratios, 1e9 N/m springs, a 50-link rope, a four-bar through
# and near its change point, a fast top.  extreme_test asserts;
# simulate_extreme_table (not built by default, not a test) prints the
# docs' table: cmake --build build --target simulate_extreme_table.
if(NOT JRGEN_TEST_SUBSET)
  set(_x ${CMAKE_CURRENT_SOURCE_DIR}/simulate/extreme)
  add_jr_solver(TARGET sim_x_dp6 URDF ${_x}/dp_light_tip_1e6.urdf NAMESPACE sim_x_dp6)
  add_jr_solver(TARGET sim_x_dp9 URDF ${_x}/dp_light_tip_1e9.urdf NAMESPACE sim_x_dp9)
  add_jr_solver(TARGET sim_x_dp12 URDF ${_x}/dp_light_tip_1e12.urdf NAMESPACE sim_x_dp12)
  add_jr_solver(TARGET sim_x_dph6 URDF ${_x}/dp_heavy_tip_1e6.urdf NAMESPACE sim_x_dph6)
  add_jr_solver(TARGET sim_x_dph9 URDF ${_x}/dp_heavy_tip_1e9.urdf NAMESPACE sim_x_dph9)
  add_jr_solver(TARGET sim_x_dp15 URDF ${_x}/dp_light_tip_1e15.urdf NAMESPACE sim_x_dp15)
  add_jr_solver(TARGET sim_x_spring URDF ${_x}/spring_1e9.urdf NAMESPACE sim_x_spring)
  add_jr_solver(TARGET sim_x_pspring URDF ${_x}/point_spring_1e9.urdf NAMESPACE sim_x_pspring)
  add_jr_solver(TARGET sim_x_rope URDF ${_x}/rope50.urdf NAMESPACE sim_x_rope)
  add_jr_solver(TARGET sim_x_par URDF ${_x}/parallelogram.urdf NAMESPACE sim_x_par OPTIONS --gravity 0,-9.81,0)
  add_jr_solver(TARGET sim_x_parp URDF ${_x}/parallelogram.urdf NAMESPACE sim_x_parp
                OPTIONS --gravity 0,-9.81,0 --singular proximal)
  add_jr_solver(TARGET sim_x_toggle URDF ${_x}/near_toggle.urdf NAMESPACE sim_x_toggle OPTIONS --gravity 0,-9.81,0)
  add_jr_solver(TARGET sim_x_top URDF ${_x}/top.urdf NAMESPACE sim_x_top)
  set(_x_solvers sim_x_dp6 sim_x_dp9 sim_x_dp12 sim_x_dph6 sim_x_dph9 sim_x_dp15 sim_x_spring sim_x_pspring sim_x_rope sim_x_par
                 sim_x_parp sim_x_toggle sim_x_top)
  jrgen_test(simulate_extreme_test simulate/extreme_test.cpp)
  target_link_libraries(simulate_extreme_test PRIVATE jrgen_runtime ${_x_solvers})
  target_include_directories(simulate_extreme_test PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  # The simulator of a --singular proximal solver says when it used regularized answers.
  add_jr_simulator(TARGET parallelogram_prox_sim URDF ${_x}/parallelogram.urdf NAMESPACE parallelogram_prox_sim
                   OPTIONS --gravity 0,-9.81,0 --singular proximal)
  add_test(NAME simulate_cli_regularized
           COMMAND ${CMAKE_COMMAND} -DSIM=$<TARGET_FILE:parallelogram_prox_sim> -DSIM0=$<TARGET_FILE:fourbar_sim>
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/simulate/check_regularized_cli.cmake)
  add_executable(simulate_extreme_table EXCLUDE_FROM_ALL simulate/extreme_table.cpp)
  target_link_libraries(simulate_extreme_table PRIVATE jrgen_runtime ${_x_solvers})
  target_include_directories(simulate_extreme_table PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_compile_definitions(simulate_extreme_table PRIVATE JRGEN_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()

# ---- many runs (jrgen/batch.hpp; docs/simulation.md "Many runs: threads and MPI") ----
jrgen_test(simulate_batch_test simulate/batch_test.cpp)
target_link_libraries(simulate_batch_test PRIVATE fourbar_sim_dyn)

# The MPI example (examples/batch_mpi) and its bitwise test, when MPI is found.
find_package(MPI COMPONENTS CXX)
if(MPI_CXX_FOUND AND MPIEXEC_EXECUTABLE)
  add_subdirectory(${PROJECT_SOURCE_DIR}/examples/batch_mpi ${CMAKE_CURRENT_BINARY_DIR}/batch_mpi)
  # Open MPI refuses root without --allow-run-as-root (CI runs as root) and
  # more ranks than cores without --oversubscribe.
  execute_process(COMMAND "${MPIEXEC_EXECUTABLE}" --version OUTPUT_VARIABLE _mpi_version ERROR_QUIET)
  set(_mpi_flags "")
  if(_mpi_version MATCHES "Open MPI|OpenRTE")
    set(_mpi_flags --allow-run-as-root,--oversubscribe)  # ','-separated: one argument below
  endif()
  add_test(NAME simulate_batch_mpi
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:jrgen_batch_mpi> -DMPIEXEC=${MPIEXEC_EXECUTABLE}
                   "-DMPIFLAGS=${_mpi_flags}" -DWORK=${CMAKE_CURRENT_BINARY_DIR}/simulate_batch_mpi
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/simulate/check_batch_mpi.cmake)
  set_tests_properties(simulate_batch_mpi PROPERTIES TIMEOUT 600)
else()
  # Not left out silently: the test is there and skips (ctest lists it; CI's
  # skip gate, .ci/allowed-skips, fails on it).
  message(STATUS "MPI (C++) not found: examples/batch_mpi is not built and the test simulate_batch_mpi skips "
                 "(Debian: apt-get install openmpi-bin libopenmpi-dev)")
  add_test(NAME simulate_batch_mpi COMMAND ${CMAKE_COMMAND} -E echo
           "MPI (C++) not found at configure time: install openmpi-bin libopenmpi-dev and configure again")
  set_tests_properties(simulate_batch_mpi PROPERTIES SKIP_REGULAR_EXPRESSION "MPI \\(C\\+\\+\\) not found")
endif()
