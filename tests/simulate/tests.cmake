# ---- time integration (runtime/include/jrgen/simulate.hpp, docs/simulation.md) ----
jrgen_test(simulate_ode_test simulate/ode_test.cpp)
target_link_libraries(simulate_ode_test PRIVATE jrgen_runtime)
