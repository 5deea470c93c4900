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

# The simulator executable of add_jr_simulator() (INTERFACE.md section 7):
# CSV header, rows, last stdout line, errors (check_simulator.cmake).
add_jr_simulator(TARGET fourbar_sim URDF ${PROJECT_SOURCE_DIR}/models/fourbar.urdf NAMESPACE fourbar_sim)
add_test(NAME simulate_cli_test
         COMMAND ${CMAKE_COMMAND} -DSIM=$<TARGET_FILE:fourbar_sim> -DWORK=${CMAKE_CURRENT_BINARY_DIR}/simulate_cli
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/simulate/check_simulator.cmake)
