// One report program per model (tests/report/CMakeLists.txt): the model's two
// generated solvers (--method llt and --method ldlt, compiled with
// JRGEN_EXPOSE_STEPS for the per-step timings) handed to report_core.
#include "report_core.hpp"

#include JRGEN_REPORT_LLT_HEADER
#include JRGEN_REPORT_LDLT_HEADER

// The opt-in step hook of the templates (templates/api_*.cpp.tmpl), not in
// the generated header.
namespace JRGEN_REPORT_LLT {
int solve_augmented_steps(const double* M, const double* Q, const double* Phiq, const double* gamma, int last);
}
namespace JRGEN_REPORT_LDLT {
int solve_augmented_steps(const double* M, const double* Q, const double* Phiq, const double* gamma, int last);
}

#define JRGEN_REPORT_API(ns)                                                                          \
  jrgen::report::GeneratedApi {                                                                       \
    ns::nq, ns::nv, ns::nc, ns::njoints, &ns::forward_dynamics, &ns::solve_augmented, &ns::mass_matrix, &ns::bias_forces,     \
        &ns::constraints, &ns::constraint_jacobian, &ns::constraint_gamma, &ns::last_error,           \
        &ns::solve_augmented_steps                                                                    \
  }

int main(int argc, char** argv) {
  const jrgen::report::ModelInfo info{JRGEN_REPORT_MODEL, JRGEN_REPORT_URDF, JRGEN_REPORT_CUTS};
  return jrgen::report::run(argc, argv, info, JRGEN_REPORT_API(JRGEN_REPORT_LLT),
                            JRGEN_REPORT_API(JRGEN_REPORT_LDLT));
}
