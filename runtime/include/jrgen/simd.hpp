// Pairs of doubles for the generated straight-line code (Steps 1 and 3.1).
//
// Two neighbouring entries of a column of the packed factor have the same
// form in eq. (26): L[k, j] and L[k', j] (k' the parent of k) both subtract
// L[j, i] L[., i] over the same descendants i, and their L[., i] sit next to
// each other in column i (Lemma 2 layout: column i holds i and its
// ancestors, nearest first).  Likewise two constraint rows of one row of T
// (Step 3.1) whose sums run over the same descendants.  The generator writes
// such pairs as one statement on a v2d, which the compiler turns into one
// SSE2 (or NEON) instruction per operation instead of two: the code gets
// shorter and the arithmetic stays the same, lane by lane and in the same
// order (so the results are bitwise those of the scalar statements).
// JRGEN_PORTABLE_SIMD selects the plain-C++ fallback on any compiler.
#pragma once

#include <atomic>
#include <cstring>

namespace jr {

#if (defined(__GNUC__) || defined(__clang__)) && !defined(JRGEN_PORTABLE_SIMD)
/// Two doubles in one register; arithmetic is element-wise, and a double
/// operand is broadcast to both lanes.
typedef double v2d __attribute__((vector_size(16)));
inline v2d set2(double a, double b) { return v2d{a, b}; }
#else
/// Portable fallback with the same operations (element-wise, in order).
struct v2d {
  double x[2];
};
inline v2d set2(double a, double b) { return v2d{{a, b}}; }
inline v2d operator+(v2d a, v2d b) { return set2(a.x[0] + b.x[0], a.x[1] + b.x[1]); }
inline v2d operator-(v2d a, v2d b) { return set2(a.x[0] - b.x[0], a.x[1] - b.x[1]); }
inline v2d operator*(v2d a, double s) { return set2(a.x[0] * s, a.x[1] * s); }
inline v2d operator*(double s, v2d a) { return set2(s * a.x[0], s * a.x[1]); }
inline v2d operator*(v2d a, v2d b) { return set2(a.x[0] * b.x[0], a.x[1] * b.x[1]); }
inline v2d operator/(v2d a, double s) { return set2(a.x[0] / s, a.x[1] / s); }
inline v2d& operator+=(v2d& a, v2d b) { return a = a + b; }
inline v2d operator-(v2d a) { return set2(-a.x[0], -a.x[1]); }
#endif

/// a[0] + a[1].
#if (defined(__GNUC__) || defined(__clang__)) && !defined(JRGEN_PORTABLE_SIMD)
inline double sum2(v2d a) { return a[0] + a[1]; }
#else
inline double sum2(v2d a) { return a.x[0] + a.x[1]; }
#endif

/// p[0], p[1] (any alignment).
inline v2d load2(const double* p) {
  v2d r;
  std::memcpy(&r, p, sizeof r);
  return r;
}

/// p[0] = v[0], p[1] = v[1] (any alignment).
inline void store2(double* p, v2d v) { std::memcpy(p, &v, sizeof v); }

/// A compiler-only barrier (no instruction is emitted): values computed
/// before it reach the statements after it through memory, not registers.
/// The generator writes one between blocks of the long straight-line steps
/// of large models (every kFenceProducts products).  Without it GCC carries
/// hundreds of values from one block to the next in registers and spills
/// most of them to the stack: on the HMMWV a third of Step 1's and Step
/// 3.1's instructions were stack traffic.  Reading the stored entries back
/// costs a store-to-load forwarding instead; the HMMWV solve runs 5% faster,
/// legged30's 11% (docs/benchmarks.md, run 8).
inline void compiler_fence() { std::atomic_signal_fence(std::memory_order_seq_cst); }

}  // namespace jr
