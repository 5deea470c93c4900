#include <array>
#include <cstdio>

#include "hmmwv_dyn.hpp"  // written by add_jr_solver(TARGET hmmwv_dyn ... NAMESPACE hmmwv)

// qdd (nv numbers) at the state q (nq), v (nv) under the joint forces tau (nv).
int accelerations(const double* q, const double* v, const double* tau, double* qdd) {
  // lambda holds nc numbers; a tree has nc = 0 (there, nullptr works as well).
  std::array<double, (hmmwv::nc > 0 ? hmmwv::nc : 1)> lambda{};
  const int status = hmmwv::forward_dynamics(q, v, tau, qdd, lambda.data());
  if (status != hmmwv::kSuccess)  // 1: M singular, 2: loop rows singular, 3: NaN or infinity
    std::fprintf(stderr, "jrgen: %s\n", hmmwv::last_error());
  return status;
}
