#include <cstdio>

int arm_forward_dynamics_at_rest(int* nv);

int main() {
  int nv = 0;
  const int rc = arm_forward_dynamics_at_rest(&nv);
  std::printf("arm: nv = %d, forward_dynamics -> %d\n", nv, rc);
  return rc == 0 ? 0 : 1;
}
