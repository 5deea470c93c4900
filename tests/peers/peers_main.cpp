// One peers program per model (tests/peers/CMakeLists.txt): the model's
// generated solver handed to peers_core.
#include "peers_core.hpp"

#include JRGEN_PEERS_HEADER

int main(int argc, char** argv) {
  namespace g = JRGEN_PEERS_NS;
  const jrgen::peers::GeneratedApi api{g::nq,
                                       g::nv,
                                       g::nc,
                                       g::njoints,
                                       g::joint_names,
                                       g::joint_q_index,
                                       g::joint_v_index,
                                       &g::forward_dynamics,
                                       &g::solve_augmented,
                                       &g::mass_matrix,
                                       &g::bias_forces,
                                       &g::constraints,
                                       &g::constraint_jacobian,
                                       &g::constraint_gamma};
  const jrgen::peers::ModelInfo info{JRGEN_PEERS_MODEL, JRGEN_PEERS_URDF, JRGEN_PEERS_CUTS, JRGEN_PEERS_MJ_COMPILER,
                                     JRGEN_PEERS_MJ_URDF};
  return jrgen::peers::run(argc, argv, info, api);
}
