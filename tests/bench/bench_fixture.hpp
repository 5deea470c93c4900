// The model fixture of the solver benchmarks (tests/bench/solve_benchmark.cpp):
// random states, the mass matrix and right-hand side built once outside the
// timed loops, an extended-precision reference solution and the error measures
// every timing is reported with.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <string>
#include <vector>

namespace jrgen::bench {

/// The generated API (docs/interface.md section 4) of one solver, as plain pointers.
struct SolverApi {
  int nq, nv;
  int (*forward_dynamics)(const double* q, const double* v, const double* tau, double* qdd,
                          double* lambda);
  int (*solve_augmented)(const double* M, const double* Q, const double* Phiq, const double* gamma,
                         double* qdd, double* lambda);
  void (*mass_matrix)(const double* q, double* M);
  void (*bias_forces)(const double* q, const double* v, double* h);
};

struct State {
  Eigen::VectorXd q, v, tau;
};

using VectorXld = Eigen::Matrix<long double, Eigen::Dynamic, 1>;

struct Problem {
  int nv = 0;
  int dense_max_nv = 0;
  std::vector<State> states;  ///< 16 random states; M and Q come from states[0]
  Eigen::MatrixXd M;          ///< mass_matrix(q0), dense column-major, user order
  Eigen::VectorXd Q;          ///< tau0 - h(q0, v0)
  Eigen::SparseMatrix<double> M_sparse;  ///< lower triangle of M, exact zeros dropped
  long nnz_lower = 0;                    ///< structural non-zeros of M's lower triangle (= of L)
  VectorXld x_ref;                       ///< reference solution, long double
  std::string reference_kind;
  long double M_fro = 0, Q_norm = 0;
  double cond1_estimate = 0;  ///< 1 / Eigen::LLT::rcond() (dense sizes only)
  bool have_gen = false, have_dense = false;
  Eigen::VectorXd x_gen, x_llt, x_lu;  ///< each method's solution, for the mutual differences

  /// ||x - x_ref|| / ||x_ref|| (2-norms, long double).
  double forward_error(const Eigen::VectorXd& x) const;
  /// ||Q - M x|| / (||M||_F ||x|| + ||Q||), residual in long double.
  double backward_error(const Eigen::VectorXd& x) const;
  /// Q - M x in long double.
  VectorXld residual(const Eigen::VectorXd& x) const;
  VectorXld residual(const VectorXld& x) const;
};

/// Random states (seeded; q, v, tau uniform in [-1, 1]; quaternions are
/// normalized by the solver), M, Q, the reference and every method's solution.
Problem make_problem(const SolverApi& api, const char* model_name);

/// ||a - b|| / ||b||.
double relative_difference(const Eigen::VectorXd& a, const Eigen::VectorXd& b);

/// The zero configuration of a generated model: q = 0 but identity
/// quaternions (a joint of 4 or 7 coordinates ends with its quaternion,
/// w first: q[next - 4] = 1), from the generated joint_q_index.
std::vector<double> zero_configuration(int nq, int njoints, const int* joint_q_index);

}  // namespace jrgen::bench
