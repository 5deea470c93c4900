#include "analysis/constraints.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>

#include "analysis/cut_definitions.hpp"
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
    case ir::CutType::Mimic: return "mimic";
  }
  return "?";
}

// The element a cut came from, for messages: a <mimic> row is named after its joint.
const char* cut_element(const ir::CutJoint& ic) { return ic.type == ir::CutType::Mimic ? "mimic" : "loop_joint"; }

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

// Cholesky factor of the Gram matrix G = Phiq Phiq^T + mu I (mu >= 0: the
// Levenberg-Marquardt term, 0 for the rank tests) in an elimination order
// of the rows, dropping dependent rows: in position j, the pivot
// d_j = |row - its projection on the kept rows before it|^2 + mu (Gram-Schmidt
// in the metric of G); a row is dependent when d_j <= tol * G_jj.  The pattern is
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

  GramFactor factor(const std::vector<double>& Phiq, double tol, double mu) const {
    const int m = static_cast<int>(order_.size());
    GramFactor f;
    f.pattern = pattern_;
    f.L.resize(m);
    f.diag.assign(m, 0.0);
    f.dropped.assign(m, 0);
    std::vector<double> x(m, 0.0);
    for (int j = 0; j < m; ++j) {  // left-looking, dense scatter of column j
      const int rj = order_[j];
      const double Gjj = gram(Phiq, rj, rj) + mu;
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

  // Damped minimum-norm Newton step on the rows S the factor keeps:
  // dv = -Phiq_S^T (Phiq_S Phiq_S^T + mu I)^-1 phi_S (nv, user order); with
  // mu = 0 the minimum-norm Newton step, with mu > 0 the Levenberg-Marquardt
  // step (Phiq^T Phiq + mu I)^-1 Phiq^T phi written in its dual form.
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

// ---- Units and tolerances (docs/assembly.md, "Tolerances") --------------------
//
// Rows measure lengths (point, across-axis and distance rows, in the model's
// unit) or are dimensionless (dot rows); velocity coordinates are translations
// or rotations (rad).  With a length scale L of the model, assembly and the
// rank tests work on the scaled problem
//   (a)  phi~ = S phi,   Phiq~ = S Phiq D,   dv = D dv~,
// S = 1/L on length rows (1 on dot rows), D = L on translational coordinates
// (1 on rotations).  Drawing a mechanism s times larger multiplies L, the
// length rows and the translations by s and leaves (a) unchanged, so a
// mechanism drawn in millimetres, metres or kilometres assembles the same way
// and keeps the same rows.  Every tolerance below is one of (a): on length rows
// it is relative to L.

// L: the largest offset the model draws between neighbouring frames (tree
// joint origins, fixed joints folded in; cut frames on their bodies; given
// distances); 1 when every frame coincides.
double length_scale(const topology::Tree& tree) {
  double L = 0.0;
  for (const topology::Body& b : tree.bodies) L = std::max(L, b.X_PJ.p.norm());
  for (const topology::Cut& c : tree.cuts) {
    L = std::max({L, c.X_BkF.p.norm(), c.X_BlF.p.norm()});
    if (c.distance_given) L = std::max(L, std::abs(c.distance));
  }
  return L > 0.0 && std::isfinite(L) ? L : 1.0;
}

// Whether a row of a cut type measures a length (runtime.hpp, CutKind).
bool length_row(ir::CutType type, int row) {
  switch (type) {
    case ir::CutType::Spherical:
    case ir::CutType::Distance: return true;
    case ir::CutType::Revolute:
    case ir::CutType::Universal:
    case ir::CutType::Fixed: return row < 3;
    case ir::CutType::Prismatic: return row >= 3;
    case ir::CutType::Cylindrical: return row >= 2;
    case ir::CutType::Mimic: return false;  // in the units of the joints' coordinates
  }
  return true;
}


struct Scaling {
  double length = 1.0;           ///< L
  std::vector<double> row;       ///< S per row (AllRows numbering)
  std::vector<double> dof_user;  ///< D per velocity coordinate, user order
};

Scaling scaling(const topology::Tree& tree) {
  Scaling s;
  s.length = length_scale(tree);
  for (const topology::Cut& c : tree.cuts)
    for (int r = 0; r < c.rows; ++r) s.row.push_back(length_row(c.type, r) ? 1.0 / s.length : 1.0);
  s.dof_user.assign(tree.nv, 1.0);
  for (const topology::Body& b : tree.bodies)
    for (int k = 0; k < b.nv; ++k)
      if (topology::dof_translates(b.type, k)) s.dof_user[b.v_user + k] = s.length;
  return s;
}

// Tolerances on max |phi~| (a).  Phi~ is computed with an absolute rounding
// error of a few eps per joint on the two paths of a cut (relative to L on
// length rows), about 1e-14 for hundreds of joints: the iteration stops below
// kConverged = 1e-12; a start counts as assembled below kAssembled = 1e-9 (a
// nanometre on a metre-sized mechanism), a perturbed configuration used for the
// row selection below kPerturbed = 1e-10; a default distance below
// kCoincident = 1e-9 is 0.
constexpr double kConverged = 1e-12;
constexpr double kAssembled = 1e-9;
constexpr double kPerturbed = 1e-10;
constexpr double kCoincident = 1e-9;
// A seeded start that assembles where a kept pivot of the Gram factor is
// below 1e-8 of the largest diagonal entry (a singular value of the kept rows
// of Phiq~ below about 1e-4 of the largest) has found a singular
// configuration; later starts are tried for a regular one.
constexpr double kRegularPivot = 1e-8;

// Levenberg-Marquardt on 0.5 |phi~|^2 (b): the damping is mu = m |phi~|_2
// (Fan & Yuan 2005: with mu proportional to |phi~| the iteration converges
// quadratically onto zero-residual solutions, also where Phiq is rank
// deficient there, as at redundant cuts); m follows the ratio rho of actual to
// predicted decrease (Nielsen 1999): a step is accepted when rho > 1e-4, then
// m *= max(1/3, 1 - (2 rho - 1)^3), nu = 2; else m *= nu, nu *= 2.  A start
// is abandoned after kMaxIterations, when m exceeds kMaxDamping (no step
// decreases |phi~|) or when the step is below kNegligibleStep (a stationary
// point of |phi~|^2 that is not a solution, e.g. a four-bar drawn stretched:
// every link collinear with the gap, no joint moves the gap's direction).
constexpr double kInitialDamping = 1e-3;
constexpr double kAcceptRatio = 1e-4;
constexpr double kMaxDamping = 1e16;
constexpr int kMaxIterations = 100;
constexpr double kNegligibleStep = 1e-14;

// Seeded starts (c): the zero configuration moved by dv with rotations
// uniform in [-a_k, a_k] and translations in [-a_k L, a_k L], a_k = pi/8,
// pi/4, pi/2, then pi (continuation from small perturbations of the drawing to
// arbitrary joint angles); a portable generator with a fixed seed makes the
// starts, and so the output, deterministic.
constexpr int kSeededStarts = 16;
constexpr std::uint64_t kSeed = 0x6a72676e61737365ULL;  // "jrgnasse"

// Assembly of the loops of a tree by (b) in the units (a), on the Gram
// system of the Lemma 3 pattern: time and memory follow its fill, not rows x nv.
class Assembler {
 public:
  Assembler(const topology::Tree& tree, RuntimeModel& rt)
      : tree_(tree),
        rt_(rt),
        all_(all_rows(tree)),
        gram_(tree, all_, topology::constraint_row_order(tree, all_.rows_per_cut).order),
        scale_(scaling(tree)) {}

  const Scaling& scale() const { return scale_; }
  const GramSystem& gram() const { return gram_; }
  RuntimeModel& runtime() { return rt_; }

  // phi~ and the packed Phiq~ (a) at q (either may be null).
  void evaluate(const Eigen::VectorXd& q, Eigen::VectorXd* phi, std::vector<double>* Phiq) {
    evaluate_all_rows(rt_, all_, q, phi, Phiq);
    if (phi) *phi = phi->cwiseProduct(Eigen::Map<const Eigen::VectorXd>(scale_.row.data(), all_.rows));
    if (!Phiq) return;
    for (std::size_t c = 0; c < tree_.cuts.size(); ++c) {
      const jr::CutModel& cm = all_.cuts[c];
      for (int r = 0; r < tree_.cuts[c].rows; ++r) {
        double* p = Phiq->data() + cm.phiq_start + r * cm.num_dofs;
        const double s = scale_.row[all_.first_row[c] + r];
        for (int i = 0; i < cm.num_dofs; ++i) p[i] *= s * scale_.dof_user[tree_.dof_user[tree_.cuts[c].dofs[i]]];
      }
    }
  }

  // max |phi~| at q.
  double residual(const Eigen::VectorXd& q) {
    Eigen::VectorXd phi;
    evaluate(q, &phi, nullptr);
    return max_abs(phi);
  }

  // (b) from q; q holds the last accepted iterate.  Returns max |phi~| there.
  double solve(Eigen::VectorXd& q);

  // The smallest pivot of the Gram factor at q among the rows it keeps,
  // relative to the largest diagonal entry of the Gram matrix: about
  // (sigma_min / sigma_max)^2 of the kept rows of Phiq~; small where q is a
  // singular configuration (a row independent only within its own, tiny,
  // norm, as the in-line rows of a four-bar folded flat).
  double smallest_pivot(const Eigen::VectorXd& q) {
    std::vector<double> Phiq;
    evaluate(q, nullptr, &Phiq);
    const GramFactor f = gram_.factor(Phiq, kGramPivotTolerance, 0.0);
    double largest = 0.0, smallest = INFINITY;
    for (int r = 0; r < all_.rows; ++r) largest = std::max(largest, gram_.gram(Phiq, r, r));
    for (double d : f.diag)
      if (d > 0.0) smallest = std::min(smallest, d * d);
    return largest > 0.0 ? smallest / largest : 1.0;
  }

  static double max_abs(const Eigen::VectorXd& x) { return x.size() ? x.cwiseAbs().maxCoeff() : 0.0; }

 private:
  // Phiq~ dv~ (rows, AllRows numbering; dv~ user order).
  Eigen::VectorXd jacobian_times(const std::vector<double>& Phiq, const Eigen::VectorXd& dv) const {
    Eigen::VectorXd out(all_.rows);
    for (std::size_t c = 0; c < tree_.cuts.size(); ++c) {
      const topology::Cut& cut = tree_.cuts[c];
      for (int r = 0; r < cut.rows; ++r) {
        const double* p = Phiq.data() + all_.cuts[c].phiq_start + r * all_.cuts[c].num_dofs;
        double sum = 0.0;
        for (int i = 0; i < cut.num_distinct; ++i) sum += p[i] * dv[tree_.dof_user[cut.dofs[i]]];
        out[all_.first_row[c] + r] = sum;
      }
    }
    return out;
  }

  const topology::Tree& tree_;
  RuntimeModel& rt_;
  const AllRows all_;
  const GramSystem gram_;
  const Scaling scale_;
};

double Assembler::solve(Eigen::VectorXd& q) {
  Eigen::VectorXd phi, phi_trial;
  std::vector<double> Phiq, Phiq_trial;
  evaluate(q, &phi, &Phiq);
  const Eigen::Map<const Eigen::VectorXd> D(scale_.dof_user.data(), tree_.nv);
  double m = kInitialDamping, nu = 2.0;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double r = max_abs(phi);
    if (!std::isfinite(r) || r < kConverged || tree_.nv == 0) break;
    // The damped step of (b), dv~ = -Phiq~^T (Phiq~ Phiq~^T + mu I)^-1 phi~.
    const double f = 0.5 * phi.squaredNorm();
    const Eigen::VectorXd step =
        gram_.newton_step(gram_.factor(Phiq, kGramPivotTolerance, m * phi.norm()), Phiq, phi);
    if (!(max_abs(step) > kNegligibleStep)) break;
    const double predicted = f - 0.5 * (phi + jacobian_times(Phiq, step)).squaredNorm();
    Eigen::VectorXd q_trial = q;
    integrate(tree_, q_trial, step.cwiseProduct(D));
    evaluate(q_trial, &phi_trial, &Phiq_trial);
    const double rho = (f - 0.5 * phi_trial.squaredNorm()) / predicted;
    if (predicted > 0.0 && rho > kAcceptRatio) {
      q.swap(q_trial);
      phi.swap(phi_trial);
      Phiq.swap(Phiq_trial);
      m *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
      nu = 2.0;
    } else {
      m *= nu;
      nu *= 2.0;
      if (m > kMaxDamping) break;
    }
  }
  return max_abs(phi);
}

// Angles of revolute, continuous and planar joints into [-pi, pi] (the same
// configuration, easier to read).
void wrap_angles(const topology::Tree& tree, Eigen::VectorXd& q) {
  for (const topology::Body& b : tree.bodies) {
    if (b.type == ir::JointType::Revolute || b.type == ir::JointType::Continuous)
      q[b.q_user] = std::remainder(q[b.q_user], 2.0 * M_PI);
    if (b.type == ir::JointType::Planar) q[b.q_user + 2] = std::remainder(q[b.q_user + 2], 2.0 * M_PI);
  }
}

// q0 moved by a seeded dv: rotations uniform in [-a, a] rad,
// translations in [-a L, a L] (L from the scaling).
Eigen::VectorXd perturbed(const topology::Tree& tree, const Scaling& scale, const Eigen::VectorXd& q0, double a,
                          std::uint64_t& state) {
  Eigen::VectorXd q = q0, dv(tree.nv);
  for (int i = 0; i < tree.nv; ++i) dv[i] = a * scale.dof_user[i] * uniform(state);
  integrate(tree, q, dv);
  return q;
}

// Max |phi| of every cut (model units) and the cut with the largest max |phi~|.
struct CutResiduals {
  std::vector<double> per_cut;
  int worst = 0;
};

CutResiduals cut_residuals(const topology::Tree& tree, Assembler& as, const Eigen::VectorXd& q) {
  Eigen::VectorXd phi;
  as.evaluate(q, &phi, nullptr);
  CutResiduals out;
  double worst = -1.0;
  for (int c = 0, offset = 0; c < static_cast<int>(tree.cuts.size()); offset += tree.cuts[c].rows, ++c) {
    double scaled = 0.0, model = 0.0;
    for (int r = 0; r < tree.cuts[c].rows; ++r) {
      scaled = std::max(scaled, std::abs(phi[offset + r]));
      model = std::max(model, std::abs(phi[offset + r]) / as.scale().row[offset + r]);
    }
    out.per_cut.push_back(model);
    if (!(scaled <= worst)) {
      worst = scaled;
      out.worst = c;
    }
  }
  return out;
}

struct Assembly {
  Eigen::VectorXd q;  ///< assembled, user order
  std::string start;  ///< which start assembled
  double residual = 0.0;  ///< max |phi| there (model units)
  bool moved = false;     ///< q is not the drawing (zero configuration), or came from --assemble-from
  bool singular = false;  ///< Phiq nearly loses rank at q (moved only; Assembler::smallest_pivot)
  double drawn_residual = 0.0;
  int drawn_worst = 0;         ///< cut with the largest residual in the drawing
  double user_residual = 0.0;  ///< where the --assemble-from start failed, max |phi| reached from it
  std::string user_against;    ///< the cut whose rows alone the --assemble-from start closed
};

// Start k of (c): -1 the user's, 0 the zero configuration q0, 1..kSeededStarts
// seeded (drawn in turn from `state`).
Eigen::VectorXd start_configuration(int k, const topology::Tree& tree, const Scaling& scale, const Eigen::VectorXd& q0,
                                    const Eigen::VectorXd* user_start, std::uint64_t& state) {
  if (k < 0) return *user_start;
  if (k == 0) return q0;
  return perturbed(tree, scale, q0, M_PI * std::min(1.0, 0.0625 * (1 << std::min(k, 4))), state);
}

std::string start_name(int k, const std::string& user_file) {
  if (k < 0) return "the start in " + user_file;
  return k == 0 ? "the zero configuration" : fmt::format("seeded start {} of {}", k, kSeededStarts);
}

double largest(const std::vector<double>& x) { return x.empty() ? 0.0 : *std::max_element(x.begin(), x.end()); }

// Tries the starts in order (c): the user's (--assemble-from), the zero
// configuration, kSeededStarts seeded ones; the first that (b) brings below
// kAssembled wins, but a seeded start that lands on a singular configuration
// is kept only when no later one lands on a regular one.  Throws "the loop
// cannot be closed" when none assembles.
Assembly find_assembly(const ir::Robot& robot, const topology::Tree& tree, Assembler& as,
                       const Eigen::VectorXd* user_start, const std::string& user_file) {
  const Eigen::VectorXd q0 = neutral_configuration(tree);
  Assembly out;
  const CutResiduals drawn = cut_residuals(tree, as, q0);
  out.drawn_worst = drawn.worst;
  out.drawn_residual = drawn.per_cut[drawn.worst];
  const bool drawn_assembled = as.residual(q0) < kAssembled;
  std::uint64_t state = kSeed;
  Eigen::VectorXd best_q;
  double best = std::numeric_limits<double>::infinity();
  std::optional<Assembly> singular;
  int against_definition = -1;  // a cut whose rows closed with a reversed axis or a half turn
  for (int k = user_start ? -1 : 0; k <= kSeededStarts; ++k) {
    Eigen::VectorXd q = start_configuration(k, tree, as.scale(), q0, user_start, state);
    const double r = as.solve(q);
    if (!(r < kAssembled)) {
      if (k < 0) out.user_residual = largest(cut_residuals(tree, as, q).per_cut);
      if (!(r >= best)) best = r, best_q = q;
      continue;
    }
    // Rows at zero, definition not (cut_definitions.hpp): a start that moved
    // the mechanism there found another mechanism, not an assembly.  A drawing
    // closed as drawn is the user's and is kept as before.
    if (k != 0 || !drawn_assembled) {
      const int c = cut_against_definition(tree, as.runtime(), q);
      if (c >= 0) {
        if (against_definition < 0) against_definition = c;
        if (k < 0) out.user_against = tree.cuts[c].name;
        continue;
      }
    }
    wrap_angles(tree, q);
    Assembly found = out;
    found.q = q;
    found.start = start_name(k, user_file);
    found.residual = largest(cut_residuals(tree, as, q).per_cut);
    found.moved = k != 0 || !drawn_assembled;
    if (k == 0) return found;  // the drawing, as before: no rank test
    found.singular = as.smallest_pivot(q) < kRegularPivot;
    if (k < 0 || !found.singular) return found;
    if (!singular) singular = found;
  }
  if (singular) return *singular;
  if (against_definition >= 0) {
    const topology::Cut& cut = tree.cuts[against_definition];
    const ir::CutJoint& ic = robot.cuts[cut.cut_ir];
    throw Error(ic.where, cut_element(ic), ic.name,
                fmt::format("the loop cannot be closed as defined: its rows close only with {} (docs/interface.md "
                            "section 2); check <origin>, <child_origin> and <axis>, or give a start near an "
                            "assembled configuration with --assemble-from Q.txt (docs/assembly.md)",
                            cut.type == ir::CutType::Fixed ? "the two frames half a turn apart"
                                                           : "the axis on the child reversed or the frames "
                                                             "half a turn apart"));
  }
  const CutResiduals at_best = cut_residuals(tree, as, best_q.size() ? best_q : q0);
  const ir::CutJoint& ic = robot.cuts[tree.cuts[at_best.worst].cut_ir];
  throw Error(ic.where, cut_element(ic), ic.name,
              fmt::format("the loop cannot be closed: Levenberg-Marquardt from {}the zero configuration and {} "
                          "seeded starts (joint angles up to +-pi) leaves a constraint residual of {:.3g} here at "
                          "best (inconsistent constraints?); check <origin>, <child_origin>, <axis> and "
                          "<distance>, or give a start near an assembled configuration with --assemble-from "
                          "Q.txt (docs/assembly.md)",
                          user_start ? "the start in " + user_file + ", " : "", kSeededStarts,
                          at_best.per_cut[at_best.worst]));
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

double model_length_scale(const topology::Tree& tree) { return length_scale(tree); }

double assemble(const topology::Tree& tree, RuntimeModel& rt, Eigen::VectorXd& q) {
  Assembler as(tree, rt);
  return as.solve(q);
}

namespace {

// Default distances: at the zero configuration (docs/interface.md section 2); a
// distance below kCoincident L is 0, an error.
void default_distances(const ir::Robot& robot, topology::Tree& tree) {
  const double L = length_scale(tree);
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
    if (!(cut.distance > kCoincident * L)) {
      const ir::CutJoint& ic = robot.cuts[cut.cut_ir];
      throw Error(ic.where, cut_element(ic), ic.name,
                  "the two frames coincide at the zero configuration, so the default distance is 0; "
                  "give <distance value=\"...\"/> (a spherical cut may be what you want)");
    }
  }
}

// The assembly note (stderr) and section (--report) when the configuration
// used is not the drawing, or came from --assemble-from.
void describe_assembly(const ir::Robot& robot, const topology::Tree& tree, const Assembly& a,
                       const std::string& user_file, ConstraintAnalysis& out) {
  const std::vector<std::string> names = coordinate_names(tree);
  const std::string drawn = a.drawn_residual > 0.0
      ? fmt::format("the loops are open at the zero configuration (largest residual {:.3g}, {} joint '{}')",
                    a.drawn_residual, tree.cuts[a.drawn_worst].type == ir::CutType::Mimic ? "mimic" : "loop",
                    tree.cuts[a.drawn_worst].name)
      : "the zero configuration is assembled";
  std::string how = fmt::format("{}; assembled from {} (largest residual {:.1e})", drawn, a.start, a.residual);
  if (!a.user_against.empty())
    how += fmt::format(" after the start in {} did not assemble (it closes the rows of loop joint '{}' with a "
                       "reversed axis or frames half a turn apart)",
                       user_file, a.user_against);
  if (a.user_residual > 0.0)
    how += fmt::format(" after the start in {} did not assemble (largest residual {:.3g} from it)", user_file,
                       a.user_residual);
  if (a.singular) how += ", a singular configuration (Phiq nearly loses rank there)";
  std::string values;
  constexpr int kNoteValues = 24;
  for (int i = 0; i < tree.nq && i < kNoteValues; ++i) values += fmt::format("{}{:.10g}", i ? " " : "", a.q[i]);
  if (tree.nq > kNoteValues) values += fmt::format(" ... ({} more in the --report file)", tree.nq - kNoteValues);
  out.notes.push_back(fmt::format("{}: {}: q = {} (user order; a file with these numbers given to "
                                  "--assemble-from starts there)",
                                  robot.source_file, how, values));
  std::string section = "\n## Assembly\n\n" + how + " (docs/assembly.md).  The configuration used, in user order:\n\n";
  section += "| coordinate | q |\n|---|---:|\n";
  for (int i = 0; i < tree.nq; ++i) section += fmt::format("| {} | {:.17g} |\n", names[i], a.q[i]);
  out.report_section = section;
}

}  // namespace

ConstraintAnalysis analyze_constraints(const ir::Robot& robot, topology::Tree& tree, bool strict,
                                       const std::string& start_file) {
  ConstraintAnalysis out;
  if (tree.cuts.empty()) {
    if (!start_file.empty()) {
      read_start_configuration(start_file, tree);
      out.notes.push_back(start_file + ": the model has no loop joints; --assemble-from is not used");
    }
    return out;
  }
  default_distances(robot, tree);

  RuntimeModel rt(tree, Eigen::Vector3d::Zero());
  const int rows = total_rows(tree);
  // Every row, packed (Lemma 3), scaled (a), and the elimination order of
  // the Gram matrix Phiq Phiq^T: assembly and row selection stay sparse.
  Assembler as(tree, rt);

  // Assemble (find_assembly), then at two seeded perturbations of the
  // assembled configuration.
  Eigen::VectorXd user_start;
  if (!start_file.empty()) user_start = read_start_configuration(start_file, tree);
  const Assembly assembly = find_assembly(robot, tree, as, start_file.empty() ? nullptr : &user_start, start_file);
  if (assembly.moved) describe_assembly(robot, tree, assembly, start_file, out);
  std::vector<Eigen::VectorXd> configs = {assembly.q};
  {
    std::uint64_t state = 0x6a72676e;  // "jrgn"
    for (int k = 0; k < 2; ++k) {
      Eigen::VectorXd qp = perturbed(tree, as.scale(), configs.front(), 0.2, state);
      if (as.solve(qp) < kPerturbed) configs.push_back(qp);
    }
  }

  // Greedy row selection: keep a row if, at some assembled configuration, it
  // is independent of the rows before it in the elimination order that stay
  // at that configuration: the pivot-dropping Cholesky factorization of the
  // scaled Gram matrix (a) (GramSystem; the order is the natural cut-row
  // order unless minimum degree gives less fill, topology::constraint_row_order).
  std::vector<char> independent(rows, 0);
  for (const Eigen::VectorXd& q : configs) {
    std::vector<double> Phiq;
    as.evaluate(q, nullptr, &Phiq);
    const GramFactor f = as.gram().factor(Phiq, kGramPivotTolerance, 0.0);
    for (int r = 0; r < rows; ++r)
      if (!f.dropped[as.gram().position(r)]) independent[r] = 1;
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
      if (strict)
        throw Error(ic.where, cut_element(ic), ic.name,
                    what + " (--strict-constraints); leave the option out to let jrgen drop them (docs/urdf.md, "
                           "redundant rows)");
      out.notes.push_back(Error(ic.where, cut_element(ic), ic.name, what + "; dropped").what());
    }
    cut.kept_rows = kept;
    offset += cut.rows;
  }
  out.configurations = configs;
  return out;
}

}  // namespace jrgen::analysis
