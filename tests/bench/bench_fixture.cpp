#include "bench_fixture.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <stdexcept>

namespace jrgen::bench {

namespace {

constexpr int kNumStates = 16;
constexpr int kRefinementSteps = 4;

Eigen::VectorXd uniform(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = u(rng);
  return x;
}

long double norm(const VectorXld& x) {
  long double s = 0;
  for (Eigen::Index i = 0; i < x.size(); ++i) s += x[i] * x[i];
  return std::sqrt(s);
}

}  // namespace

VectorXld Problem::residual(const VectorXld& x) const {
  VectorXld r = Q.cast<long double>();
  for (int j = 0; j < nv; ++j) {
    const long double xj = x[j];
    const double* col = M.data() + static_cast<std::size_t>(j) * nv;
    for (int i = 0; i < nv; ++i) r[i] -= static_cast<long double>(col[i]) * xj;
  }
  return r;
}

VectorXld Problem::residual(const Eigen::VectorXd& x) const { return residual(VectorXld(x.cast<long double>())); }

double Problem::forward_error(const Eigen::VectorXd& x) const {
  return static_cast<double>(norm(x.cast<long double>() - x_ref) / norm(x_ref));
}

double Problem::backward_error(const Eigen::VectorXd& x) const {
  const long double xn = norm(x.cast<long double>());
  return static_cast<double>(norm(residual(x)) / (M_fro * xn + Q_norm));
}

double relative_difference(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).norm() / b.norm();
}

Problem make_problem(const SolverApi& api, const char* model_name) {
  Problem p;
  p.nv = api.nv;
  const char* env = std::getenv("JRGEN_BENCH_DENSE_MAX_NV");
  p.dense_max_nv = env ? std::atoi(env) : 4000;
  std::mt19937_64 rng(20240601);
  for (int k = 0; k < kNumStates; ++k)
    p.states.push_back({uniform(rng, api.nq), uniform(rng, api.nv), uniform(rng, api.nv)});

  const State& s0 = p.states[0];
  p.M.resize(p.nv, p.nv);
  api.mass_matrix(s0.q.data(), p.M.data());
  Eigen::VectorXd h(p.nv);
  api.bias_forces(s0.q.data(), s0.v.data(), h.data());
  p.Q = s0.tau - h;

  std::vector<Eigen::Triplet<double>> triplets;
  long double fro = 0;
  for (int j = 0; j < p.nv; ++j)
    for (int i = 0; i < p.nv; ++i) {
      const double m = p.M(i, j);
      fro += static_cast<long double>(m) * m;
      if (i >= j && m != 0.0) triplets.emplace_back(i, j, m);
    }
  p.M_fro = std::sqrt(fro);
  p.Q_norm = norm(p.Q.cast<long double>());
  p.nnz_lower = static_cast<long>(triplets.size());
  p.M_sparse.resize(p.nv, p.nv);
  p.M_sparse.setFromTriplets(triplets.begin(), triplets.end());

  p.x_gen.resize(p.nv);
  p.have_gen = api.solve_augmented(p.M.data(), p.Q.data(), nullptr, nullptr, p.x_gen.data(), nullptr) == 0;
  p.have_dense = p.nv <= p.dense_max_nv;
  if (p.have_dense) {
    Eigen::LLT<Eigen::MatrixXd> llt(p.M);
    p.x_llt = llt.solve(p.Q);
    p.cond1_estimate = 1.0 / llt.rcond();
    p.x_lu = Eigen::PartialPivLU<Eigen::MatrixXd>(p.M).solve(p.Q);
    // Reference: Cholesky in long double (64-bit mantissa) on the exact M,
    // then refinement with long-double residuals.
    using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
    Eigen::LLT<MatrixXld> llt_ld(p.M.cast<long double>());
    if (llt_ld.info() != Eigen::Success) throw std::runtime_error("long double LLT failed");
    p.x_ref = llt_ld.solve(p.Q.cast<long double>());
    for (int it = 0; it < kRefinementSteps; ++it) p.x_ref += llt_ld.solve(p.residual(p.x_ref));
    p.reference_kind = "long double LLT + long double refinement";
  } else {
    // Too large for a dense long-double factorization: mixed-precision
    // iterative refinement (iterate and residual in long double, corrections
    // by the generated solve).  Its fixed point is the solution of M x = Q
    // whatever the correction solver, provided cond(M) eps << 1.
    if (!p.have_gen) throw std::runtime_error("generated solve failed: no reference");
    p.x_ref = p.x_gen.cast<long double>();
    Eigen::VectorXd r(p.nv), d(p.nv);
    for (int it = 0; it < kRefinementSteps; ++it) {
      r = p.residual(p.x_ref).cast<double>();
      api.solve_augmented(p.M.data(), r.data(), nullptr, nullptr, d.data(), nullptr);
      p.x_ref += d.cast<long double>();
    }
    p.reference_kind = "iterative refinement: long double residual, generated-solve corrections";
  }
  std::fprintf(stderr, "%s: nv = %d, reference: %s\n", model_name, p.nv, p.reference_kind.c_str());
  return p;
}

std::vector<double> zero_configuration(int nq, int njoints, const int* joint_q_index) {
  std::vector<double> q(nq, 0.0);
  for (int j = 0; j < njoints; ++j) {
    const int next = j + 1 < njoints ? joint_q_index[j + 1] : nq;
    const int nqj = next - joint_q_index[j];
    if (nqj == 4 || nqj == 7) q[next - 4] = 1.0;
  }
  return q;
}

}  // namespace jrgen::bench
