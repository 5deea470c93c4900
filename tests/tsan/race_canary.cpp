// A known data race, for scripts/tsan.sh: two OpenMP threads add to one
// double without synchronization.  ThreadSanitizer must report it (exit 66);
// if it does not, TSan or Archer is not active in that build and the
// script's zero reports on the real programs would prove nothing.
#include <cstdio>

int main() {
  double sum = 0;
#pragma omp parallel for num_threads(2) schedule(static, 1)
  for (int i = 0; i < 1000; ++i) sum += i;  // the race
  std::printf("race_canary: %g\n", sum);
  return 0;
}
