// Forward dynamics of the HMMWV model at its neutral configuration, through
// the solver that add_jr_solver() generated (hmmwv_dyn.hpp).
#include <cmath>
#include <cstdio>
#include <vector>

#include "hmmwv_dyn.hpp"

int main() {
  // Neutral configuration: every coordinate zero except the quaternions,
  // which are the identity (w = 1).  docs/interface.md section 3: a floating
  // joint's q is position (3) then quaternion w, x, y, z; a ball joint's q is
  // quaternion w, x, y, z.  The kind is read off the joint's q span.
  std::vector<double> q(hmmwv::nq, 0.0);
  for (int j = 0; j < hmmwv::njoints; ++j) {
    const int first = hmmwv::joint_q_index[j];
    const int span = (j + 1 < hmmwv::njoints ? hmmwv::joint_q_index[j + 1] : hmmwv::nq) - first;
    if (span == 7) q[first + 3] = 1.0;  // floating
    else if (span == 4) q[first] = 1.0;  // ball
  }
  std::vector<double> v(hmmwv::nv, 0.0), tau(hmmwv::nv, 0.0), qdd(hmmwv::nv, 0.0);
  std::vector<double> lambda(hmmwv::nc > 0 ? hmmwv::nc : 1, 0.0);

  const int rc = hmmwv::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data());
  std::printf("hmmwv: nq = %d, nv = %d, nc = %d, forward_dynamics -> %d %s\n", hmmwv::nq, hmmwv::nv,
              hmmwv::nc, rc, hmmwv::last_error());

  bool finite = true;
  for (double a : qdd) finite = finite && std::isfinite(a);
  const int shown = hmmwv::nv < 6 ? hmmwv::nv : 6;
  std::printf("qdd[0..%d] (%s):", shown - 1, hmmwv::joint_names[0]);
  for (int i = 0; i < shown; ++i) std::printf(" %.6g", qdd[i]);
  std::printf("\n");

  if (rc != hmmwv::kSuccess || !finite) {
    std::fprintf(stderr, "FAILED: %s\n", rc != hmmwv::kSuccess ? "non-zero result code"
                                                              : "non-finite acceleration");
    return 1;
  }
  std::printf("OK\n");
  return 0;
}
