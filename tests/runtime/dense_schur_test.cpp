// The runtime's dense Schur kernels (jrgen/constraint_solve.hpp: the dense
// part of Steps 3.3 and 3.4 that generated closed-loop solvers call when
// every constraint row reaches some common dofs) against Eigen, written
// differently: the Gram product as a dense matrix product, the factor as
// Eigen's LLT (and as the reconstruction L D L^T = W for LDL^T), the solve as
// a dense solve of the permuted system.  Sizes 1 to 40, seeded.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "common/tolerance.hpp"
#include "jrgen/constraint_solve.hpp"

namespace jrgen {
namespace {

using testing::kEps;
using testing::relative_error;

// Dense packed lower triangle by columns (the kernels' layout).
std::vector<double> pack(const Eigen::MatrixXd& A) {
  std::vector<double> W;
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = j; i < A.rows(); ++i) W.push_back(A(i, j));
  return W;
}
Eigen::MatrixXd unpack_lower(const std::vector<double>& W, int m) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, m);
  int e = 0;
  for (int j = 0; j < m; ++j)
    for (int i = j; i < m; ++i) A(i, j) = W[e++];
  return A;
}

// k x m row-major blocks of T-like data, and an SPD W = T^T T + shift.
struct Case {
  int k, m;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> A, B;
  Eigen::MatrixXd W;
  Case(int k_, int m_, unsigned seed) : k(k_), m(m_) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    A.resize(k, m);
    B.resize(k, m);
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < m; ++j) A(i, j) = u(rng), B(i, j) = u(rng);
    Eigen::MatrixXd G(m + 3, m);
    for (int i = 0; i < m + 3; ++i)
      for (int j = 0; j < m; ++j) G(i, j) = u(rng);
    W = G.transpose() * G;  // well conditioned for these sizes
  }
};

class DenseSchur : public ::testing::TestWithParam<int> {};

TEST_P(DenseSchur, GramIsATransposeB) {
  for (int k : {0, 1, 2, 3, 4, 5, 6, 7, 9}) {
    const Case c(k, GetParam(), 11 + k);
    std::vector<double> W(c.m * (c.m + 1) / 2, -7.0);  // overwritten, not accumulated
    jr::schur_dense_gram(c.A.data(), c.B.data(), k, c.m, W.data());
    const Eigen::MatrixXd ref = (c.A.transpose() * c.B).triangularView<Eigen::Lower>();
    // Each entry is a k-term dot product: |error| <= k eps sum |a_i b_i|.
    const Eigen::MatrixXd bound = (c.A.cwiseAbs().transpose() * c.B.cwiseAbs()).triangularView<Eigen::Lower>();
    const Eigen::MatrixXd got = unpack_lower(W, c.m);
    for (int j = 0; j < c.m; ++j)
      for (int i = j; i < c.m; ++i)
        EXPECT_LE(std::abs(got(i, j) - ref(i, j)), (k + 1) * kEps * bound(i, j)) << "k " << k << " (" << i << ", " << j << ")";
  }
}

TEST_P(DenseSchur, FactorMatchesEigenAndSolves) {
  const int m = GetParam();
  const Case c(1, m, 5 + m);
  // A permuted elimination order, as the generator's kSchurOrder.
  std::vector<std::int32_t> order(m);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(m));
  const double cond = [&] {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(c.W);
    return es.eigenvalues().maxCoeff() / es.eigenvalues().minCoeff();
  }();
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(m, -1.0, 2.0);
  // W in elimination positions: Wp(p, q) = W(order[p], order[q]).
  Eigen::MatrixXd Wp(m, m);
  for (int p = 0; p < m; ++p)
    for (int q = 0; q < m; ++q) Wp(p, q) = c.W(order[p], order[q]);
  const Eigen::VectorXd x_ref = c.W.llt().solve(b);
  for (bool ldlt : {false, true}) {
    std::vector<double> W = pack(Wp), Winv(m), work(m);
    double pivot = 0.0;
    ASSERT_EQ(jr::schur_dense_factor(W.data(), Winv.data(), m, ldlt, 1e-14, &pivot), -1);
    const Eigen::MatrixXd F = unpack_lower(W, m);
    Eigen::MatrixXd rebuilt;
    if (ldlt) {
      Eigen::MatrixXd Lu = F;
      Lu.diagonal().setOnes();
      rebuilt = Lu * F.diagonal().asDiagonal() * Lu.transpose();
      for (int j = 0; j < m; ++j) EXPECT_DOUBLE_EQ(Winv[j], 1.0 / F(j, j));
    } else {
      const Eigen::MatrixXd Lref = Wp.llt().matrixL();
      EXPECT_LE(relative_error(F, Lref), 4 * m * kEps * cond);
      rebuilt = F * F.transpose();
      for (int j = 0; j < m; ++j) EXPECT_DOUBLE_EQ(Winv[j], 1.0 / F(j, j));
    }
    // Backward stability of Cholesky: ||W - L L^T|| <= c m eps ||W||.
    EXPECT_LE(relative_error(rebuilt, Wp), 4 * m * kEps) << (ldlt ? "ldlt" : "llt");
    // The solve, in user row order.
    Eigen::VectorXd x = b;
    jr::schur_dense_solve(W.data(), Winv.data(), m, order.data(), ldlt, work.data(), x.data());
    EXPECT_LE(relative_error(x, x_ref), 8 * m * kEps * cond) << (ldlt ? "ldlt" : "llt");
    // The fused path of the generated code: the forward substitution rides
    // along the factorization (its own rounding), then the backward one.
    // The same factor, bitwise; the same solution to the same bound.
    std::vector<double> W2 = pack(Wp), Winv2(m);
    Eigen::VectorXd x2 = b;
    ASSERT_EQ(jr::schur_dense_factor_forward(W2.data(), Winv2.data(), m, order.data(), ldlt, 1e-14, &pivot,
                                             work.data(), x2.data()),
              -1);
    EXPECT_EQ(W2, W) << (ldlt ? "ldlt" : "llt");
    EXPECT_EQ(Winv2, Winv) << (ldlt ? "ldlt" : "llt");
    jr::schur_dense_backward(W2.data(), Winv2.data(), m, order.data(), ldlt, work.data(), x2.data());
    EXPECT_LE(relative_error(x2, x_ref), 8 * m * kEps * cond) << (ldlt ? "ldlt, fused" : "llt, fused");
  }
}

// The square layout that the generated code calls (m a template argument,
// column j from j * ld, ld = m rounded up to even) runs the arithmetic of the
// packed loops above entry by entry: bitwise the same W, factor, reciprocal
// pivots and forward solution (with FMA available the compiler may contract
// the two differently: then the same to a few roundings).  Its backward
// substitution sums in another order: checked against Eigen.
template <typename V>
void expect_same(const V& a, const V& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
#ifdef __FMA__
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-13 * (1.0 + std::abs(a[i]))) << what;
#else
  EXPECT_EQ(a, b) << what;
#endif
}

// The lower triangle of a square W (leading dimension ld), packed by columns.
std::vector<double> lower_of_square(const std::vector<double>& W, int m, int ld) {
  std::vector<double> p;
  for (int j = 0; j < m; ++j)
    for (int i = j; i < m; ++i) p.push_back(W[static_cast<std::size_t>(j) * ld + i]);
  return p;
}

std::vector<double> square(const Eigen::MatrixXd& A, int ld) {
  std::vector<double> W(static_cast<std::size_t>(ld) * ld, 0.0);
  for (Eigen::Index j = 0; j < A.cols(); ++j)
    for (Eigen::Index i = j; i < A.rows(); ++i) W[static_cast<std::size_t>(j) * ld + i] = A(i, j);
  return W;
}

template <std::int32_t K, std::int32_t M>
void expect_square_equals_packed() {
  constexpr int ld = jr::detail::kSquareLd<M>;
  static_assert(ld % 2 == 0 && ld >= M && ld <= M + 1);
  SCOPED_TRACE(::testing::Message() << "k " << K << ", m " << M);
  const Case c(K, M, 7 + M);
  {
    std::vector<double> G1(M * (M + 1) / 2, -1.0), G2(static_cast<std::size_t>(ld) * ld, -2.0);
    jr::schur_dense_gram(c.A.data(), c.B.data(), K, M, G1.data());
    jr::schur_square_gram_fixed<K, M>(c.A.data(), c.B.data(), G2.data());
    expect_same(G1, lower_of_square(G2, M, ld), "gram");
  }
  std::vector<std::int32_t> order(M);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(M));
  const double cond = [&] {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(c.W);
    return es.eigenvalues().maxCoeff() / es.eigenvalues().minCoeff();
  }();
  Eigen::MatrixXd Wp(M, M);  // in elimination positions
  for (int p = 0; p < M; ++p)
    for (int q = 0; q < M; ++q) Wp(p, q) = c.W(order[p], order[q]);
  Eigen::VectorXd b(M);
  for (int i = 0; i < M; ++i) b[i] = std::cos(2.0 + i);
  const Eigen::VectorXd x_ref = c.W.llt().solve(b);
  for (bool ldlt : {false, true}) {
    SCOPED_TRACE(ldlt ? "ldlt" : "llt");
    std::vector<double> F1 = pack(Wp), F2 = square(Wp, ld), inv1(M), inv2(M), work1(M), work2(ld, -3.0);
    std::vector<double> y1(b.data(), b.data() + M), y2 = y1;
    double p1 = 0.0, p2 = 0.0;
    ASSERT_EQ(jr::schur_dense_factor_forward(F1.data(), inv1.data(), M, order.data(), ldlt, 1e-14, &p1, work1.data(),
                                             y1.data()),
              -1);
    ASSERT_EQ(jr::schur_square_factor_forward_fixed<M>(F2.data(), inv2.data(), order.data(), ldlt, 1e-14, &p2,
                                                       work2.data(), y2.data()),
              -1);
    expect_same(F1, lower_of_square(F2, M, ld), "factor");
    expect_same(inv1, inv2, "reciprocal pivots");
    expect_same(work1, std::vector<double>(work2.begin(), work2.begin() + M), "forward solution");
    jr::schur_square_backward_fixed<M>(F2.data(), inv2.data(), order.data(), ldlt, work2.data(), y2.data());
    EXPECT_LE(relative_error(Eigen::Map<const Eigen::VectorXd>(y2.data(), M), x_ref), 8 * M * kEps * cond);
  }
  // A vanishing pivot (row and column p copies of p - 1) is reported at p.
  if constexpr (M >= 2) {
    constexpr int p = M / 2;
    Eigen::MatrixXd S = c.W;
    S.row(p) = S.row(p - 1);
    S.col(p) = S.col(p - 1);
    for (bool ldlt : {false, true}) {
      std::vector<double> W = square(S, ld), Winv(M), work(ld), z(M, 1.0);
      double pivot = 1.0;
      EXPECT_EQ(jr::schur_square_factor_forward_fixed<M>(W.data(), Winv.data(), order.data(), ldlt, 1e-10, &pivot,
                                                         work.data(), z.data()),
                p);
      EXPECT_LE(std::abs(pivot), 1e-10 * S(p, p));
    }
  }
}

TEST(DenseSchurSquare, SameArithmeticAsThePackedLoops) {
  expect_square_equals_packed<3, 1>();
  expect_square_equals_packed<1, 2>();
  expect_square_equals_packed<2, 3>();
  expect_square_equals_packed<1, 5>();
  expect_square_equals_packed<6, 8>();
  expect_square_equals_packed<4, 13>();
  expect_square_equals_packed<6, 16>();
  expect_square_equals_packed<5, 17>();
  expect_square_equals_packed<9, 31>();
  expect_square_equals_packed<7, 32>();
}

// A copied row needs two rows: the sizes from 2 (no size skipped).
class DenseSchurSingular : public ::testing::TestWithParam<int> {};

TEST_P(DenseSchurSingular, PivotIsReportedAtItsPosition) {
  const int m = GetParam();
  ASSERT_GE(m, 2);
  const Case c(1, m, 99 + m);
  // Row/column p a copy of row/column p - 1: the pivot of position p vanishes.
  const int p = m / 2;
  Eigen::MatrixXd S = c.W;
  S.row(p) = S.row(p - 1);
  S.col(p) = S.col(p - 1);
  for (bool ldlt : {false, true}) {
    std::vector<double> W = pack(S), Winv(m);
    double pivot = 1.0;
    EXPECT_EQ(jr::schur_dense_factor(W.data(), Winv.data(), m, ldlt, 1e-10, &pivot), p);
    EXPECT_LE(std::abs(pivot), 1e-10 * S(p, p));
  }
}

INSTANTIATE_TEST_SUITE_P(Sizes, DenseSchur, ::testing::Values(1, 2, 3, 5, 8, 13, 16, 17, 31, 40));
INSTANTIATE_TEST_SUITE_P(Sizes, DenseSchurSingular, ::testing::Values(2, 3, 5, 8, 13, 16, 17, 31, 40));

}  // namespace
}  // namespace jrgen
