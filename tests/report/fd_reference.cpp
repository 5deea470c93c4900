#include "fd_reference.hpp"

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "reference/reference_constraints.hpp"
#include "reference/reference_dynamics.hpp"

namespace jrgen::report {

namespace {
using MatrixXld = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
using VectorXld = Eigen::Matrix<long double, Eigen::Dynamic, 1>;

// Every row of every cut, stacked: Phiq (rows x nv) and gamma.
void reference_rows(const ir::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                    Eigen::MatrixXd& Phiq, Eigen::VectorXd& gamma) {
  int rows = 0;
  for (const ir::CutJoint& cut : robot.cuts) rows += ir::cut_rows(cut.type);
  Phiq.resize(rows, v.size());
  gamma.resize(rows);
  int r = 0;
  for (const ir::CutJoint& cut : robot.cuts) {
    Eigen::Vector3d axis, u, w;
    reference::axis_basis(cut, axis, u, w);
    const reference::CutRows c = reference::cut_rows(robot, cut, reference::cut_distance(robot, cut), u, w, q, v);
    Phiq.middleRows(r, c.Phiq.rows()) = c.Phiq;
    gamma.segment(r, c.gamma.size()) = c.gamma;
    r += static_cast<int>(c.Phiq.rows());
  }
}
}  // namespace

Eigen::VectorXd reference_qdd(const ir::Robot& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                              const Eigen::VectorXd& tau, const Eigen::Vector3d& gravity) {
  const MatrixXld M = reference::mass_matrix(robot, q).cast<long double>();
  const VectorXld Q = (tau - reference::bias_forces(robot, q, v, gravity)).cast<long double>();
  const Eigen::LLT<MatrixXld> llt(M);
  VectorXld qdd = llt.solve(Q);
  if (!robot.cuts.empty()) {
    Eigen::MatrixXd Phiq_d;
    Eigen::VectorXd gamma_d;
    reference_rows(robot, q, v, Phiq_d, gamma_d);
    const MatrixXld Phiq = Phiq_d.cast<long double>();
    const MatrixXld T = llt.solve(MatrixXld(Phiq.transpose()));
    const MatrixXld W = Phiq * T;
    // Redundant rows make W singular up to the rounding of the double-precision
    // rows (~1e-16 relative): pivots below 1e-10 of the largest are dropped.
    Eigen::CompleteOrthogonalDecomposition<MatrixXld> cod;
    cod.setThreshold(1e-10L);
    cod.compute(W);
    const VectorXld lambda = cod.solve(VectorXld(Phiq * qdd - gamma_d.cast<long double>()));
    qdd -= T * lambda;
  }
  return qdd.cast<double>();
}

double relative_error(const Eigen::VectorXd& x, const Eigen::VectorXd& ref) {
  return (x - ref).norm() / ref.norm();
}

}  // namespace jrgen::report
