// jrgen demo: runs the generated solver of the default model and reports its
// sizes, its time per call and its error against a dense reference solve of
// the same equations (17) with Eigen (LU of the augmented matrix, refined
// once in long double).
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "demo_solver.hpp"

namespace {

// q <- q "+" dv along velocity coordinates (docs/interface.md section 3): plain
// addition, quaternions by the exponential map of the angular part.
void integrate(Eigen::VectorXd& q, const Eigen::VectorXd& dv) {
  for (int j = 0; j < demo::njoints; ++j) {
    const int q0 = demo::joint_q_index[j], v0 = demo::joint_v_index[j];
    const int q1 = j + 1 < demo::njoints ? demo::joint_q_index[j + 1] : demo::nq;
    const int v1 = j + 1 < demo::njoints ? demo::joint_v_index[j + 1] : demo::nv;
    if (q1 - q0 == v1 - v0) {
      q.segment(q0, q1 - q0) += dv.segment(v0, v1 - v0);
      continue;
    }
    // ball (4/3) or floating (7/6: translation first): quaternion last.
    q.segment(q0, q1 - q0 - 4) += dv.segment(v0, v1 - v0 - 3);
    const Eigen::Vector3d w = dv.segment<3>(v1 - 3);
    Eigen::Quaterniond quat(q[q1 - 4], q[q1 - 3], q[q1 - 2], q[q1 - 1]);
    if (w.norm() > 0) quat = quat * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
    quat.normalize();
    q.segment<4>(q1 - 4) << quat.w(), quat.x(), quat.y(), quat.z();
  }
}

// A random assembled state: the zero configuration moved by a random step,
// then Newton-projected onto Phi(q) = 0; v random with Phiq v = 0.
void random_state(std::mt19937_64& rng, Eigen::VectorXd& q, Eigen::VectorXd& v, Eigen::VectorXd& tau) {
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  q = Eigen::VectorXd::Zero(demo::nq);
  for (int j = 0; j < demo::njoints; ++j) {
    const int q1 = j + 1 < demo::njoints ? demo::joint_q_index[j + 1] : demo::nq;
    const int v1 = j + 1 < demo::njoints ? demo::joint_v_index[j + 1] : demo::nv;
    if (q1 - demo::joint_q_index[j] != v1 - demo::joint_v_index[j]) q[q1 - 4] = 1.0;  // identity quaternion
  }
  integrate(q, Eigen::VectorXd::NullaryExpr(demo::nv, [&] { return 0.1 * u(rng); }));
  v = Eigen::VectorXd::NullaryExpr(demo::nv, [&] { return u(rng); });
  tau = Eigen::VectorXd::NullaryExpr(demo::nv, [&] { return 10.0 * u(rng); });
  if (demo::nc == 0) return;
  Eigen::VectorXd phi(demo::nc);
  Eigen::MatrixXd J(demo::nc, demo::nv);
  for (int it = 0; it < 50; ++it) {
    demo::constraints(q.data(), phi.data());
    if (phi.cwiseAbs().maxCoeff() < 1e-12) break;
    demo::constraint_jacobian(q.data(), J.data());
    integrate(q, -J.completeOrthogonalDecomposition().solve(phi));
  }
  demo::constraint_jacobian(q.data(), J.data());
  v -= J.transpose() * (J * J.transpose()).ldlt().solve(J * v);
}

template <typename F>
double median_ns(F&& f, int calls) {
  std::vector<double> samples;
  for (int rep = 0; rep < 15; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < calls; ++i) f();
    const auto t1 = std::chrono::steady_clock::now();
    samples.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() / calls);
  }
  std::sort(samples.begin(), samples.end());
  return samples[samples.size() / 2];
}

}  // namespace

int main() {
  std::printf("jrgen demo: %s%s%s\n", JRGEN_DEMO_MODEL, JRGEN_DEMO_CUTS[0] ? " + " : "", JRGEN_DEMO_CUTS);
  std::printf("  nq = %d, nv = %d, nc = %d, joints = %d\n", demo::nq, demo::nv, demo::nc, demo::njoints);

  std::mt19937_64 rng(1);
  Eigen::VectorXd q, v, tau;
  random_state(rng, q, v, tau);
  Eigen::VectorXd qdd(demo::nv), lambda(std::max(demo::nc, 1));
  const int status = demo::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data());
  if (status != 0) {
    std::printf("  forward_dynamics failed (%d): %s\n", status, demo::last_error());
    return 1;
  }

  // Dense reference of eq. (17) from the same M, h, Phiq, gamma.
  const int n = demo::nv, m = demo::nc;
  Eigen::MatrixXd M(n, n), Phiq(std::max(m, 1), n);
  Eigen::VectorXd h(n), gamma(std::max(m, 1));
  demo::mass_matrix(q.data(), M.data());
  demo::bias_forces(q.data(), v.data(), h.data());
  demo::constraint_jacobian(q.data(), Phiq.data());
  demo::constraint_gamma(q.data(), v.data(), gamma.data());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + m, n + m);
  Eigen::VectorXd b(n + m);
  A.topLeftCorner(n, n) = M;
  b.head(n) = tau - h;
  if (m > 0) {
    A.topRightCorner(n, m) = Phiq.topRows(m).transpose();
    A.bottomLeftCorner(m, n) = Phiq.topRows(m);
    b.tail(m) = gamma.head(m);
  }
  Eigen::VectorXd x = A.partialPivLu().solve(b);
  // One step of refinement with the residual in long double.
  {
    Eigen::Matrix<long double, Eigen::Dynamic, 1> r = b.cast<long double>() - A.cast<long double>() * x.cast<long double>();
    x += A.partialPivLu().solve(r.cast<double>());
  }
  const double err_qdd = (qdd - x.head(n)).norm() / std::max(x.head(n).norm(), 1e-300);
  std::printf("  relative error of qdd against the dense reference: %.2e\n", err_qdd);
  if (m > 0) {
    const Eigen::VectorXd f = Phiq.topRows(m).transpose() * lambda.head(m);
    const Eigen::VectorXd f_ref = Phiq.topRows(m).transpose() * x.tail(m);
    std::printf("  relative error of Phiq^T lambda:                   %.2e\n",
                (f - f_ref).norm() / std::max(f_ref.norm(), 1e-300));
  }

  Eigen::VectorXd Q = tau - h;
  const double t_fd = median_ns([&] { demo::forward_dynamics(q.data(), v.data(), tau.data(), qdd.data(), lambda.data()); }, 2000);
  const double t_solve = median_ns([&] { demo::solve_augmented(M.data(), Q.data(), Phiq.data(), gamma.data(), qdd.data(), lambda.data()); }, 20000);
  const double t_dense = median_ns([&] { x = A.partialPivLu().solve(b); }, 2000);
  std::printf("  time per call (median of 15 batches):\n");
  std::printf("    forward_dynamics (kinematics + M + h + solve): %8.3f us\n", t_fd * 1e-3);
  std::printf("    solve_augmented  (generated Steps 0-4):        %8.3f us\n", t_solve * 1e-3);
  std::printf("    dense Eigen PartialPivLU of eq. (17):          %8.3f us  (%.1fx the generated solve)\n",
              t_dense * 1e-3, t_dense / t_solve);
  return err_qdd < 1e-9 ? 0 : 1;
}
