# ---- time integration (runtime/include/jrgen/simulate.hpp, docs/simulation.md) ----
jrgen_test(simulate_ode_test simulate/ode_test.cpp)
target_link_libraries(simulate_ode_test PRIVATE jrgen_runtime)

add_jr_solver(TARGET sim_double_pendulum URDF ${PROJECT_SOURCE_DIR}/tests/cli/double_pendulum.urdf NAMESPACE sim_dp)
add_jr_solver(TARGET sim_ball_floating URDF ${CMAKE_CURRENT_SOURCE_DIR}/simulate/ball_floating.urdf NAMESPACE sim_bf)
if(NOT JRGEN_TEST_SUBSET OR "gen_loops_fourbar_conservative" IN_LIST JRGEN_TEST_SUBSET)
  jrgen_test(simulate_mechanism_test simulate/mechanism_test.cpp)
  target_link_libraries(simulate_mechanism_test PRIVATE jrgen_model_cases jrgen_urdf
                        sim_double_pendulum sim_ball_floating gen_loops_fourbar_conservative)
endif()
