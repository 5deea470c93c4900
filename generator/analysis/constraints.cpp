#include "analysis/constraints.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <cmath>
#include <cstdint>

#include "analysis/runtime_model.hpp"
#include "ir/error.hpp"

namespace jrgen::analysis {

namespace {

// Rows of every cut, before any is dropped (names for messages; order as in
// runtime.hpp).
const char* row_name(ir::CutType type, int row) {
  static const char* kPoint[] = {"point x", "point y", "point z"};
  static const char* kOrient[] = {"orientation x", "orientation y", "orientation z"};
  static const char* kAxis[] = {"axis alignment 1", "axis alignment 2"};
  static const char* kAcross[] = {"across axis 1", "across axis 2"};
  switch (type) {
    case ir::CutType::Spherical: return kPoint[row];
    case ir::CutType::Revolute: return row < 3 ? kPoint[row] : kAxis[row - 3];
    case ir::CutType::Prismatic: return row < 3 ? kOrient[row] : kAcross[row - 3];
    case ir::CutType::Cylindrical: return row < 2 ? kAxis[row] : kAcross[row - 2];
    case ir::CutType::Universal: return row < 3 ? kPoint[row] : "axes perpendicular";
    case ir::CutType::Fixed: return row < 3 ? kPoint[row] : kOrient[row - 3];
    case ir::CutType::Distance: return "distance";
  }
  return "?";
}

// A portable uniform number in [-1, 1) from a 64-bit generator (the standard
// distributions differ between libraries; output must not).
double uniform(std::uint64_t& state) {
  state = state * 6364136223846793005ULL + 1442695040888963407ULL;
  return static_cast<double>(state >> 11) * 0x1.0p-53 * 2.0 - 1.0;
}

int total_rows(const topology::Tree& tree) {
  int n = 0;
  for (const topology::Cut& c : tree.cuts) n += c.rows;
  return n;
}

}  // namespace

Eigen::VectorXd neutral_configuration(const topology::Tree& tree) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(tree.nq);
  for (const topology::Body& b : tree.bodies) {
    if (b.type == ir::JointType::Ball) q[b.q_user] = 1.0;
    if (b.type == ir::JointType::Floating) q[b.q_user + 3] = 1.0;
  }
  return q;
}

void integrate(const topology::Tree& tree, Eigen::VectorXd& q, const Eigen::VectorXd& dv) {
  auto rotate = [&](int qi, const Eigen::Vector3d& w) {
    Eigen::Quaterniond quat(q[qi], q[qi + 1], q[qi + 2], q[qi + 3]);
    quat.normalize();
    const double angle = w.norm();
    if (angle > 0.0) quat = quat * Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
    quat.normalize();
    q[qi] = quat.w();
    q[qi + 1] = quat.x();
    q[qi + 2] = quat.y();
    q[qi + 3] = quat.z();
  };
  for (const topology::Body& b : tree.bodies) {
    switch (b.type) {
      case ir::JointType::Ball: rotate(b.q_user, dv.segment<3>(b.v_user)); break;
      case ir::JointType::Floating:
        q.segment<3>(b.q_user) += dv.segment<3>(b.v_user);
        rotate(b.q_user + 3, dv.segment<3>(b.v_user + 3));
        break;
      default: q.segment(b.q_user, b.nv) += dv.segment(b.v_user, b.nv); break;
    }
  }
}

double assemble(const topology::Tree& tree, RuntimeModel& rt, Eigen::VectorXd& q, double tolerance,
                int max_iterations) {
  const int rows = total_rows(tree);
  Eigen::VectorXd phi(rows);
  Eigen::MatrixXd Phiq(rows, tree.nv);
  double residual = 0.0;
  for (int it = 0; it <= max_iterations; ++it) {
    jr::constraints_all_rows(rt.model(), rt.constraints(), rt.workspace(), rt.motion(), q.data(), phi.data(),
                             Phiq.data());
    residual = phi.cwiseAbs().maxCoeff();
    if (!std::isfinite(residual) || residual < tolerance || it == max_iterations) break;
    // Minimum-norm Newton step; the rank decision ignores rows that are
    // dependent (redundant constraints are consistent once assembled).
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(Phiq);
    cod.setThreshold(1e-10);
    const Eigen::VectorXd dv = -cod.solve(phi);
    integrate(tree, q, dv);
  }
  return residual;
}

ConstraintAnalysis analyze_constraints(const ir::Robot& robot, topology::Tree& tree, bool strict) {
  ConstraintAnalysis out;
  if (tree.cuts.empty()) return out;

  // Default distances: at the zero configuration (INTERFACE.md section 2).
  {
    RuntimeModel rt(tree, Eigen::Vector3d::Zero());
    const Eigen::VectorXd q0 = neutral_configuration(tree);
    jr::kinematics(rt.model(), rt.workspace(), q0.data());
    jr::world_poses(rt.model(), rt.workspace());
    auto world_origin = [&](int body, const ir::Pose& X_BF) -> Eigen::Vector3d {
      if (body < 0) return X_BF.p;
      const jr::BodyState& b = rt.workspace()[body];
      return b.p_WC + b.R_WC * X_BF.p;
    };
    for (topology::Cut& cut : tree.cuts) {
      if (cut.type != ir::CutType::Distance || cut.distance_given) continue;
      cut.distance = (world_origin(cut.body_l, cut.X_BlF) - world_origin(cut.body_k, cut.X_BkF)).norm();
      if (!(cut.distance > 1e-9)) {
        const ir::CutJoint& ic = robot.cuts[cut.cut_ir];
        throw Error(ic.where, "loop_joint", ic.name,
                    "the two frames coincide at the zero configuration, so the default distance is 0; "
                    "give <distance value=\"...\"/> (a spherical cut may be what you want)");
      }
    }
  }

  RuntimeModel rt(tree, Eigen::Vector3d::Zero());
  const int rows = total_rows(tree);

  // Assemble at the zero configuration, then at two seeded perturbations of it.
  std::vector<Eigen::VectorXd> configs;
  {
    Eigen::VectorXd q = neutral_configuration(tree);
    const double residual = assemble(tree, rt, q);
    if (!(residual < 1e-9)) {
      // Name the cut with the largest residual at the last iterate.
      Eigen::VectorXd phi(rows);
      jr::constraints_all_rows(rt.model(), rt.constraints(), rt.workspace(), rt.motion(), q.data(), phi.data(),
                               nullptr);
      int worst = 0, offset = 0;
      double worst_value = -1.0;
      for (int c = 0; c < static_cast<int>(tree.cuts.size()); ++c) {
        const double v = phi.segment(offset, tree.cuts[c].rows).cwiseAbs().maxCoeff();
        if (!(v <= worst_value)) {
          worst_value = v;
          worst = c;
        }
        offset += tree.cuts[c].rows;
      }
      const ir::CutJoint& ic = robot.cuts[tree.cuts[worst].cut_ir];
      throw Error(ic.where, "loop_joint", ic.name,
                  fmt::format("the loop cannot be closed: starting from the zero configuration, the constraint "
                              "residual stays at {:.3g} here (inconsistent constraints); check <origin>, "
                              "<child_origin>, <axis> and <distance>",
                              worst_value));
    }
    configs.push_back(q);
    std::uint64_t state = 0x6a72676e;  // "jrgn"
    for (int k = 0; k < 2; ++k) {
      Eigen::VectorXd qp = configs.front();
      Eigen::VectorXd dv(tree.nv);
      for (int i = 0; i < tree.nv; ++i) dv[i] = 0.2 * uniform(state);
      integrate(tree, qp, dv);
      if (assemble(tree, rt, qp) < 1e-10) configs.push_back(qp);
    }
  }

  // Greedy row selection: keep a row if, at some assembled configuration, it
  // is independent of the rows kept before it (Gram-Schmidt, twice).
  std::vector<Eigen::MatrixXd> jacobians;
  for (const Eigen::VectorXd& q : configs) {
    Eigen::MatrixXd Phiq(rows, tree.nv);
    jr::constraints_all_rows(rt.model(), rt.constraints(), rt.workspace(), rt.motion(), q.data(), nullptr,
                             Phiq.data());
    jacobians.push_back(Phiq);
  }
  std::vector<std::vector<Eigen::VectorXd>> basis(configs.size());
  constexpr double kIndependent = 1e-8;  // relative residual of a row after projection
  int offset = 0;
  for (topology::Cut& cut : tree.cuts) {
    std::vector<int> kept, dropped;
    for (int r = 0; r < cut.rows; ++r) {
      bool independent = false;
      std::vector<Eigen::VectorXd> residuals(configs.size());
      for (std::size_t k = 0; k < configs.size(); ++k) {
        Eigen::VectorXd a = jacobians[k].row(offset + r).transpose();
        const double norm = a.norm();
        for (int pass = 0; pass < 2; ++pass)
          for (const Eigen::VectorXd& b : basis[k]) a -= b.dot(a) * b;
        residuals[k] = a;
        if (norm > 0.0 && a.norm() > kIndependent * norm) independent = true;
      }
      if (independent) {
        kept.push_back(r);
        for (std::size_t k = 0; k < configs.size(); ++k) {
          const double n = residuals[k].norm();
          const double norm = jacobians[k].row(offset + r).norm();
          if (n > kIndependent * norm && n > 0.0) basis[k].push_back(residuals[k] / n);
        }
      } else {
        dropped.push_back(r);
      }
    }
    if (!dropped.empty()) {
      const ir::CutJoint& ic = robot.cuts[cut.cut_ir];
      std::string list;
      for (int r : dropped) list += fmt::format("{}{} ({})", list.empty() ? "" : ", ", r + 1, row_name(cut.type, r));
      const std::string what =
          fmt::format("{} of its {} rows ({}) are redundant at the assembled configurations: {}", dropped.size(),
                      cut.rows, ir::cut_type_name(cut.type), list);
      if (strict) throw Error(ic.where, "loop_joint", ic.name, what + " (--strict-constraints)");
      out.notes.push_back(Error(ic.where, "loop_joint", ic.name, what + "; dropped").what());
    }
    cut.kept_rows = kept;
    offset += cut.rows;
  }
  out.configurations = configs;
  return out;
}

}  // namespace jrgen::analysis
