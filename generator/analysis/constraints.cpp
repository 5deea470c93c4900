#include "analysis/constraints.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <algorithm>
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

// Every row of every cut (row masks ignored), in the packed Lemma 3 layout of
// runtime.hpp: the runtime's own tables with all rows kept, so that the
// Jacobian costs O(rows x dofs per cut), not O(rows x nv).
struct AllRows {
  std::vector<jr::CutModel> cuts;
  jr::ConstraintModel cm{};
  std::vector<int> rows_per_cut;
  std::vector<int> first_row;  ///< per cut (ncuts + 1)
  int rows = 0;
};

AllRows all_rows(const topology::Tree& tree) {
  AllRows a;
  a.cuts = cut_models(tree);
  int phiq = 0;
  a.first_row.push_back(0);
  for (std::size_t c = 0; c < tree.cuts.size(); ++c) {
    const topology::Cut& cut = tree.cuts[c];
    jr::CutModel& cm = a.cuts[c];
    cm.row_mask = (1 << cut.rows) - 1;
    cm.first_row = a.rows;
    cm.phiq_start = phiq;
    cm.num_dofs = static_cast<std::int32_t>(cut.dofs.size());
    a.rows += cut.rows;
    phiq += cut.rows * cm.num_dofs;
    a.rows_per_cut.push_back(cut.rows);
    a.first_row.push_back(a.rows);
  }
  a.cm = {static_cast<std::int32_t>(a.cuts.size()), a.rows, phiq, a.cuts.data()};
  return a;
}

// Phi and the packed Phiq of every row at q (common-ancestor entries 0).
void evaluate_all_rows(RuntimeModel& rt, const AllRows& a, const Eigen::VectorXd& q, Eigen::VectorXd* phi,
                       std::vector<double>* Phiq) {
  if (phi) phi->resize(a.rows);
  if (Phiq) Phiq->assign(a.cm.phiq_nnz, 0.0);
  jr::constraint_terms(rt.model(), a.cm, rt.workspace(), rt.motion(), q.data(), nullptr, phi ? phi->data() : nullptr,
                       Phiq ? Phiq->data() : nullptr, nullptr);
}

// Cholesky factor of the Gram matrix G = Phiq Phiq^T in an elimination order
// of the rows, dropping dependent rows: in position j, the pivot
// d_j = |row - its projection on the kept rows before it|^2 (Gram-Schmidt in
// the metric of G); a row is dependent when d_j <= tol * G_jj.  The pattern is
// the symbolic factorization of topology::constraint_row_pattern (rows whose
// cuts share a dof), so memory and time follow the fill of that order, not
// rows^2.  Forming G squares the condition number: the pivots carry an
// absolute error of a few (terms x eps x G_jj), about 1e-14 G_jj here, so
// tol = 1e-12 (a residual of 1e-6 of the row's norm) separates dependent rows
// (pivots at rounding level) from independent ones with a margin of ~100.
constexpr double kGramPivotTolerance = 1e-12;

struct GramFactor {
  std::vector<std::vector<int>> pattern;  ///< per position, rows below (positions)
  std::vector<std::vector<double>> L;     ///< values aligned with pattern
  std::vector<double> diag;               ///< sqrt(pivot), 0 when dropped
  std::vector<char> dropped;
};

class GramSystem {
 public:
  GramSystem(const topology::Tree& tree, const AllRows& a, const std::vector<int>& order)
      : tree_(tree), a_(a), order_(order), position_(order.size()), cut_of_row_(a.rows) {
    for (std::size_t j = 0; j < order.size(); ++j) position_[order[j]] = static_cast<int>(j);
    for (std::size_t c = 0; c < tree.cuts.size(); ++c)
      for (int r = a.first_row[c]; r < a.first_row[c + 1]; ++r) cut_of_row_[r] = static_cast<int>(c);
    pattern_ = topology::symbolic_cholesky(topology::constraint_row_pattern(tree, a.rows_per_cut, order), -1, nullptr);
    row_list_.assign(order.size(), {});
    for (std::size_t j = 0; j < pattern_.size(); ++j)
      for (int r : pattern_[j]) row_list_[r].push_back(static_cast<int>(j));
  }

  // G[r, s] for rows r, s (user numbering): a merge over the dofs their cuts share.
  double gram(const std::vector<double>& Phiq, int r, int s) const {
    const int ca = cut_of_row_[r], cb = cut_of_row_[s];
    const topology::Cut& A = tree_.cuts[ca];
    const topology::Cut& B = tree_.cuts[cb];
    const double* pa = Phiq.data() + a_.cuts[ca].phiq_start + (r - a_.first_row[ca]) * a_.cuts[ca].num_dofs;
    const double* pb = Phiq.data() + a_.cuts[cb].phiq_start + (s - a_.first_row[cb]) * a_.cuts[cb].num_dofs;
    double sum = 0.0;
    for (std::size_t i = 0, k = 0; i < A.dofs.size() && k < B.dofs.size();) {
      if (A.dofs[i] < B.dofs[k]) ++i;
      else if (B.dofs[k] < A.dofs[i]) ++k;
      else sum += pa[i++] * pb[k++];
    }
    return sum;
  }

  GramFactor factor(const std::vector<double>& Phiq, double tol) const {
    const int m = static_cast<int>(order_.size());
    GramFactor f;
    f.pattern = pattern_;
    f.L.resize(m);
    f.diag.assign(m, 0.0);
    f.dropped.assign(m, 0);
    std::vector<double> x(m, 0.0);
    for (int j = 0; j < m; ++j) {  // left-looking, dense scatter of column j
      const int rj = order_[j];
      const double Gjj = gram(Phiq, rj, rj);
      x[j] = Gjj;
      for (int i : pattern_[j]) x[i] = gram(Phiq, order_[i], rj);
      for (int k : row_list_[j]) {
        if (f.dropped[k]) continue;
        const std::vector<int>& pk = pattern_[k];
        const std::size_t at = std::lower_bound(pk.begin(), pk.end(), j) - pk.begin();
        const double ljk = f.L[k][at];
        x[j] -= ljk * ljk;
        for (std::size_t e = at + 1; e < pk.size(); ++e) x[pk[e]] -= f.L[k][e] * ljk;
      }
      const double d = x[j];
      if (!(Gjj > 0.0) || !(d > tol * Gjj)) {
        f.dropped[j] = 1;
        f.L[j].assign(pattern_[j].size(), 0.0);
      } else {
        f.diag[j] = std::sqrt(d);
        f.L[j].resize(pattern_[j].size());
        for (std::size_t e = 0; e < pattern_[j].size(); ++e) f.L[j][e] = x[pattern_[j][e]] / f.diag[j];
      }
      x[j] = 0.0;
      for (int i : pattern_[j]) x[i] = 0.0;
    }
    return f;
  }

  // Minimum-norm Newton step on the rows the factor keeps:
  // dv = -Phiq_S^T (Phiq_S Phiq_S^T)^-1 phi_S (nv, user order).
  Eigen::VectorXd newton_step(const GramFactor& f, const std::vector<double>& Phiq, const Eigen::VectorXd& phi) const {
    const int m = static_cast<int>(order_.size());
    std::vector<double> y(m);
    for (int j = 0; j < m; ++j) y[j] = f.dropped[j] ? 0.0 : phi[order_[j]];
    for (int j = 0; j < m; ++j) {
      if (f.dropped[j]) continue;
      y[j] /= f.diag[j];
      for (std::size_t e = 0; e < pattern_[j].size(); ++e) y[pattern_[j][e]] -= f.L[j][e] * y[j];
    }
    for (int j = 0; j < m; ++j)
      if (f.dropped[j]) y[j] = 0.0;
    for (int j = m - 1; j >= 0; --j) {
      if (f.dropped[j]) continue;
      double s = y[j];
      for (std::size_t e = 0; e < pattern_[j].size(); ++e) s -= f.L[j][e] * y[pattern_[j][e]];
      y[j] = s / f.diag[j];
    }
    Eigen::VectorXd dv = Eigen::VectorXd::Zero(tree_.nv);
    for (std::size_t c = 0; c < tree_.cuts.size(); ++c) {
      const topology::Cut& cut = tree_.cuts[c];
      for (int r = a_.first_row[c]; r < a_.first_row[c + 1]; ++r) {
        const double yr = y[position_[r]];
        if (yr == 0.0) continue;
        const double* p = Phiq.data() + a_.cuts[c].phiq_start + (r - a_.first_row[c]) * a_.cuts[c].num_dofs;
        for (int i = 0; i < cut.num_distinct; ++i) dv[tree_.dof_user[cut.dofs[i]]] -= p[i] * yr;
      }
    }
    return dv;
  }

  int position(int row) const { return position_[row]; }

 private:
  const topology::Tree& tree_;
  const AllRows& a_;
  std::vector<int> order_, position_, cut_of_row_;
  std::vector<std::vector<int>> pattern_, row_list_;
};

// Sparse minimum-norm Newton projection onto Phi(q) = 0 (see assemble()).
double assemble_sparse(const topology::Tree& tree, RuntimeModel& rt, const AllRows& a, const GramSystem& gs,
                       Eigen::VectorXd& q, double tolerance, int max_iterations) {
  Eigen::VectorXd phi;
  std::vector<double> Phiq;
  double residual = 0.0;
  for (int it = 0; it <= max_iterations; ++it) {
    evaluate_all_rows(rt, a, q, &phi, &Phiq);
    residual = a.rows ? phi.cwiseAbs().maxCoeff() : 0.0;
    if (!std::isfinite(residual) || residual < tolerance || it == max_iterations) break;
    // Rows dependent at this iterate are left out of the step (redundant
    // constraints are consistent once assembled).
    const Eigen::VectorXd dv = gs.newton_step(gs.factor(Phiq, kGramPivotTolerance), Phiq, phi);
    integrate(tree, q, dv);
  }
  return residual;
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
  const AllRows a = all_rows(tree);
  const GramSystem gs(tree, a, topology::constraint_row_order(tree, a.rows_per_cut).order);
  return assemble_sparse(tree, rt, a, gs, q, tolerance, max_iterations);
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
  // Every row, packed (Lemma 3), and the elimination order of the Gram
  // matrix Phiq Phiq^T: assembly and row selection stay sparse.
  const AllRows all = all_rows(tree);
  const topology::RowOrder order = topology::constraint_row_order(tree, all.rows_per_cut);
  const GramSystem gram(tree, all, order.order);
  auto assemble = [&](Eigen::VectorXd& q) { return assemble_sparse(tree, rt, all, gram, q, 1e-12, 60); };

  // Assemble at the zero configuration, then at two seeded perturbations of it.
  std::vector<Eigen::VectorXd> configs;
  {
    Eigen::VectorXd q = neutral_configuration(tree);
    const double residual = assemble(q);
    if (!(residual < 1e-9)) {
      // Name the cut with the largest residual at the last iterate.
      Eigen::VectorXd phi;
      evaluate_all_rows(rt, all, q, &phi, nullptr);
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
      if (assemble(qp) < 1e-10) configs.push_back(qp);
    }
  }

  // Greedy row selection: keep a row if, at some assembled configuration, it
  // is independent of the rows before it in the elimination order that stay
  // at that configuration: the pivot-dropping Cholesky factorization of the
  // Gram matrix (GramSystem; the order is the natural cut-row order unless
  // minimum degree gives less fill, topology::constraint_row_order).
  std::vector<char> independent(rows, 0);
  for (const Eigen::VectorXd& q : configs) {
    std::vector<double> Phiq;
    evaluate_all_rows(rt, all, q, nullptr, &Phiq);
    const GramFactor f = gram.factor(Phiq, kGramPivotTolerance);
    for (int r = 0; r < rows; ++r)
      if (!f.dropped[gram.position(r)]) independent[r] = 1;
  }
  int offset = 0;
  for (topology::Cut& cut : tree.cuts) {
    std::vector<int> kept, dropped;
    for (int r = 0; r < cut.rows; ++r) (independent[offset + r] ? kept : dropped).push_back(r);
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
