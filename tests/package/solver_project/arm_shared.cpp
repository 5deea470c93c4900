#include <cmath>
#include <vector>

#include "arm_dyn.hpp"

// Forward dynamics at q = v = tau = 0; returns the result code, or -1 when an
// acceleration is not finite.  Exported from a shared library.
int arm_forward_dynamics_at_rest(int* nv) {
  std::vector<double> q(arm::nq, 0.0), v(arm::nv, 0.0), tau(arm::nv, 0.0), qdd(arm::nv, 0.0);
  for (int j = 0; j < arm::njoints; ++j) {  // identity quaternions, if any
    const int first = arm::joint_q_index[j];
    const int span = (j + 1 < arm::njoints ? arm::joint_q_index[j + 1] : arm::nq) - first;
    if (span == 7) q[first + 3] = 1.0;
    else if (span == 4) q[first] = 1.0;
  }
  *nv = arm::nv;
  const int rc = arm::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), nullptr);
  for (double a : qdd)
    if (!std::isfinite(a)) return -1;
  return rc;
}
