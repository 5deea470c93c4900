// The source of jrgen_solver_pch (tests/CMakeLists.txt): a target that only
// builds the precompiled header the generated test solvers reuse.
#include <jrgen/runtime.hpp>
