// Full forward dynamics side by side (issue 20, item 3): one program per
// model (peers_main.cpp, compiled with the model's generated solver) times, in
// one process with Google Benchmark's random interleaving of repetitions,
//
//   jrgen/forward_dynamics                 the generated call
//   jrgen/mass_matrix, jrgen/bias_forces   its parts (they overlap: the call
//   jrgen/constraint_jacobian+gamma        computes the kinematics once)
//   jrgen/solve_augmented                  on M, tau - h, Phiq, gamma from the API
//   mujoco/mj_forward                      mujoco_urdf.hpp (trees without ball joints)
//   pinocchio/aba, pinocchio/crba+nle+cholesky   with -DJRGEN_PINOCCHIO_SOURCE
//
// on one state, and reports for every call that returns qdd its error against
// the reference (fd_reference.hpp: counter err_ref) and against jrgen's qdd
// (err_jrgen), both |x - y|_2 / |y|_2.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace jrgen::peers {

/// The generated API (docs/interface.md section 4) as plain pointers.
struct GeneratedApi {
  int nq, nv, nc, njoints;
  const char* const* joint_names;
  const int* joint_q_index;
  const int* joint_v_index;
  int (*forward_dynamics)(const double* q, const double* v, const double* tau, double* qdd, double* lambda);
  int (*solve_augmented)(const double* M, const double* Q, const double* Phiq, const double* gamma, double* qdd,
                         double* lambda);
  void (*mass_matrix)(const double* q, double* M);
  void (*bias_forces)(const double* q, const double* v, double* h);
  void (*constraints)(const double* q, double* phi);
  void (*constraint_jacobian)(const double* q, double* Phiq);
  void (*constraint_gamma)(const double* q, const double* v, double* gamma);
};

/// The joints of the generated solver (its joint_names, joint_q_index,
/// joint_v_index), user order.
struct JointLayout {
  std::vector<std::string> names;
  std::vector<int> q0, v0, nq, nv;
};

struct ModelInfo {
  const char* name;         ///< model name
  const char* urdf;         ///< the URDF the solver was generated from
  const char* cuts;         ///< its --cuts file, or ""
  const char* mj_compiler;  ///< extra MuJoCo compiler attributes, key=value ...
  const char* mj_urdf;      ///< where to write MuJoCo's copy of the URDF
};

/// The state every call gets, in jrgen's layout.
struct State {
  Eigen::VectorXd q, v, tau;
};

/// One timed call of a peer; qdd() copies the result of the last call in
/// jrgen's velocity layout (empty: the call gives no qdd).
struct Case {
  std::string name;
  std::function<void()> run;
  std::function<void(Eigen::VectorXd&)> qdd;
};

#ifdef JRGEN_PEERS_PINOCCHIO
/// Pinocchio's cases (pinocchio_side.cpp) on the URDF's model, with the
/// joints' damping per velocity coordinate in jrgen's layout; returns "ok" or
/// why it cannot run.
std::string pinocchio_cases(const std::string& urdf, const JointLayout& joints, const Eigen::VectorXd& damping,
                            const State& state, std::vector<Case>& cases);
#endif

/// Options: --quick (short timings, for a smoke run); the rest goes to
/// Google Benchmark.  Returns 0, or 1 when a check failed (status != 0, or a
/// qdd further than 1e-8 from the reference).
int run(int argc, char** argv, const ModelInfo& model, const GeneratedApi& api);

}  // namespace jrgen::peers
