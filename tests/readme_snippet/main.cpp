// Runs the README's API snippet (examples/readme_snippet/snippet.cpp) once, at
// the neutral state (every coordinate 0, identity quaternions; v = tau = 0),
// on the solver this program was built with: arm7 (a tree, nc = 0) or the
// HMMWV with its cuts (nc = 16).  Exit 0 when the snippet returns 0 and every
// acceleration is finite.
#include <cmath>
#include <cstdio>
#include <vector>

#include "hmmwv_dyn.hpp"

int accelerations(const double* q, const double* v, const double* tau, double* qdd);

int main() {
  std::vector<double> q(hmmwv::nq, 0.0), v(hmmwv::nv, 0.0), tau(hmmwv::nv, 0.0), qdd(hmmwv::nv, NAN);
  // A joint with nq - nv = 1 ends in a quaternion w, x, y, z (ball, floating).
  for (int j = 0; j < hmmwv::njoints; ++j) {
    const int q1 = j + 1 < hmmwv::njoints ? hmmwv::joint_q_index[j + 1] : hmmwv::nq;
    const int v1 = j + 1 < hmmwv::njoints ? hmmwv::joint_v_index[j + 1] : hmmwv::nv;
    if (q1 - hmmwv::joint_q_index[j] != v1 - hmmwv::joint_v_index[j]) q[q1 - 4] = 1.0;
  }
  const int status = accelerations(q.data(), v.data(), tau.data(), qdd.data());
  bool finite = true;
  for (double a : qdd) finite = finite && std::isfinite(a);
  std::printf("nq = %d, nv = %d, nc = %d: status %d, qdd %s\n", hmmwv::nq, hmmwv::nv, hmmwv::nc, status,
              finite ? "finite" : "NOT finite");
  return status == hmmwv::kSuccess && finite ? 0 : 1;
}
