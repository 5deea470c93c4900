#include "emit/terms.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "emit/articulated_terms.hpp"
#include "emit/bias_forces.hpp"
#include "emit/constraint_terms.hpp"
#include "emit/kinematics.hpp"
#include "emit/mass_matrix.hpp"
#include "emit/program.hpp"

namespace jrgen::emit {

namespace {

bool has_damping(const topology::Tree& t) {
  for (const topology::Body& b : t.bodies)
    if (b.damping != 0.0) return true;
  return false;
}

std::string bias_terms(const topology::Tree& t, const Options& options) {
  std::string bias = "Coriolis and centrifugal terms";
  if (!options.gravity.isZero(0.0)) bias += ", gravity";
  if (has_damping(t)) bias += ", joint damping";
  if (t.has_force_elements()) bias += ", springs and joint forces";
  return bias;
}

// The runtime's part of h from the force elements (section 2b), added to the
// h in `h` (Lemma 2 order); nothing for a model without them.
std::string runtime_forces_text(const topology::Tree& t, const std::string& h) {
  if (!t.has_force_elements()) return "";
  return fmt::format("  jr::force_elements(kModel, kForces, g_bodies, q, v, {});  // springs, joint forces\n", h);
}

// For the runtime's articulated-body routes, which read tau: g_tau = tau - the
// force elements' part of h (user order), and the name of the array to pass.
std::string runtime_forces_tau(const topology::Tree& t, std::string& tau) {
  tau = "tau";
  if (!t.has_force_elements()) return "";
  tau = "g_tau";
  return "  for (std::int32_t j = 0; j < nv; ++j) g_z[j] = 0.0;\n" + runtime_forces_text(t, "g_z") +
         "  for (std::int32_t j = 0; j < nv; ++j) g_tau[kDofUser[j]] = tau[kDofUser[j]] - g_z[j];\n";
}

std::string runtime_tau_workspace(const topology::Tree& t) {
  return t.has_force_elements() ? "thread_local double g_tau[nv];  // tau - the force elements' part of h\n" : "";
}

std::string runtime_flags(const topology::Tree& t, const Options& options) {
  return fmt::format("<{}, {}>", options.gravity.isZero(0.0) ? "false" : "true", has_damping(t) ? "true" : "false");
}

// The runtime's terms: generic kinematics, M by eq. (14)/(18) into g_L,
// Q = tau - h by Newton-Euler into g_z.
std::string runtime_terms_text(const topology::Tree& t, const Options& options) {
  return fmt::format(
      "  jr::kinematics(kModel, g_bodies, q);\n"
      "  // M, eq. (18), by the composite-rigid-body recursion, eq. (14).\n"
      "  jr::mass_matrix_packed(kModel, g_bodies, g_L);\n"
      "  // Q = tau - h ({}).\n"
      "  jr::bias_forces{}(kModel, g_bodies, v, g_z);\n{}"
      "  for (std::int32_t j = 0; j < nv; ++j) g_z[j] = tau[kDofUser[j]] - g_z[j];\n",
      bias_terms(t, options), runtime_flags(t, options), runtime_forces_text(t, "g_z"));
}

// The runtime's route of a tree: its terms, then the generated Steps 1, 2, 4.
std::string runtime_fd_body(const topology::Tree& t, const Options& options) {
  return runtime_terms_text(t, options) + "  const int status = solve_tree(nullptr, qdd);\n";
}

// One specialized program: its emitted functions, a driver `name` calling
// them with `args`, and its counts.
struct Built {
  Program::Emitted emitted;
  std::string definitions;
};

std::string driver(const Program::Emitted& e, const std::string& name, const std::string& params,
                   const std::string& args, const std::string& spill) {
  std::string out;
  if (e.spills > 0)
    out += fmt::format("thread_local double {}[{}];  // values passed between the parts below\n\n", spill, e.spills);
  out += e.definitions;
  out += fmt::format("void {}({}) {{\n", name, params);
  for (const std::string& call : e.calls) out += fmt::format("  {}({});\n", call, args);
  if (e.calls.empty())
    for (std::size_t at = 0; at < args.size();) {
      const std::size_t end = std::min(args.find(", ", at), args.size());
      out += fmt::format("  (void){};\n", args.substr(at, end - at));
      at = end + 2;
    }
  return out + "}\n";
}

// kinematics + articulated-body algorithm: qdd (user order), pivots D (Lemma 2).
Built articulated_program(const topology::Tree& t, const Options& options, bool fold = true) {
  const std::string params = "const double* q, const double* v, const double* tau, double* qdd, double* D";
  Program program(params, "g_aba_spill");
  program.fold_identities = fold;
  program.begin_function("articulated_terms_part", "forward_dynamics: specialized kinematics and articulated-body "
                                                   "algorithm (Featherstone 2008, Table 7.1)");
  program.begin_block("kinematics");
  program.comment("Joint transforms X_PC and motion subspaces S (constants folded, sin/cos once per joint).");
  const std::vector<BodyFrame> frames = joint_frames(program, t);
  program.comment("Body velocities and velocity-product accelerations, root first.");
  const std::vector<BodyMotion6> motion = body_velocities(program, t, frames);
  program.begin_block("articulated body (qdd = M^-1 (tau - h))");
  const ArticulatedResult aba = articulated_body(program, t, frames, motion, options.gravity);
  for (int j = 0; j < t.nv; ++j) program.output(fmt::format("qdd[{}]", t.dof_user[j]), aba.qdd[j]);
  for (int j = 0; j < t.nv; ++j) program.output(fmt::format("D[{}]", j), aba.pivots[j]);
  Built b{program.emit(), ""};
  b.definitions = driver(b.emitted, "articulated_terms", params, "q, v, tau, qdd, D", "g_aba_spill");
  return b;
}

// The blocks the tree's composite-rigid-body route and the loops share:
// kinematics, M (packed, eq. 14/18) into L, z = tau - h (Lemma 2 order).
struct Kinematics {
  std::vector<BodyFrame> frames;
  std::vector<BodyMotion6> motion;
};
Kinematics composite_blocks(Program& program, const topology::Tree& t, const Options& options) {
  program.begin_block("kinematics");
  program.comment("Joint transforms X_PC and motion subspaces S (constants folded, sin/cos once per joint).");
  Kinematics k{joint_frames(program, t), {}};
  k.motion = body_velocities(program, t, k.frames);
  program.begin_block("M (eq. 14, 18)");
  program.comment("M, eq. (18): composite inertias leaves first (eq. 14), packed as Step 1 factors it.");
  const std::vector<Value> M = mass_matrix_packed(program, t, k.frames);
  for (std::size_t i = 0; i < M.size(); ++i) program.output(fmt::format("L[{}]", i), M[i]);
  program.begin_block("h (Newton-Euler)");
  program.comment(fmt::format("Q = tau - h ({}), Lemma 2 order.", bias_terms(t, options)));
  const std::vector<Value> h = bias_forces(program, t, k.frames, k.motion, options.gravity);
  for (int j = 0; j < t.nv; ++j)
    program.output(fmt::format("z[{}]", j), program.input(fmt::format("tau[{}]", t.dof_user[j])) - h[j]);
  return k;
}

// kinematics + M + z = tau - h, for a tree's composite-rigid-body route.
Built composite_program(const topology::Tree& t, const Options& options, bool fold = true) {
  const std::string params = "const double* q, const double* v, const double* tau, double* L, double* z";
  Program program(params, "g_crb_spill");
  program.fold_identities = fold;
  program.begin_function("composite_terms_part",
                         "forward_dynamics: specialized kinematics, M (eq. 14, 18) and Q = tau - h");
  composite_blocks(program, t, options);
  Built b{program.emit(), ""};
  b.definitions = driver(b.emitted, "composite_terms", params, "q, v, tau, L, z", "g_crb_spill");
  return b;
}

// Built, within the statement limit, and with finite constants only.
bool fits(const Built& b, long long limit) {
  return !b.definitions.empty() && b.emitted.statements <= limit && b.emitted.finite;
}

// "N statements", or for a program not built because it could not fit, "too many".
std::string size_text(const Built& b) {
  if (!b.definitions.empty() && !b.emitted.finite) return "a constant that overflows";
  return b.definitions.empty() ? "too many statements" : fmt::format("{} statements", b.emitted.statements);
}

// The generation-time upper bounds of each M_jj over all configurations
// (topology::mass_diagonal_bounds), as the generated tables hold them: 0 where
// there is none (a joint below translates), and 0 throughout when not `bounded`.
std::vector<double> mass_diagonal_table(const topology::Tree& t, bool bounded = true) {
  std::vector<double> bounds = topology::mass_diagonal_bounds(t);
  for (double& b : bounds)
    if (std::isinf(b) || !bounded) b = 0.0;
  return bounds;
}

// check_articulated(), with the table it tests the pivots against: an upper
// bound of each M_jj over all configurations (topology::mass_diagonal_bounds;
// 0 where there is none, a joint below translating: then only D_j > 0).
// `bounded` false (the runtime's route, for models over the statement limit:
// long chains) writes 0 throughout: on a coiled chain of hundreds of links the
// bound exceeds M_jj by 1e4 and more, and the test would report regular
// states (docs/status.md says what is checked there).
std::string check_articulated(const topology::Tree& t, bool bounded) {
  const std::vector<double> bounds = mass_diagonal_table(t, bounded);
  return fmt::format(
      "// Upper bounds of M's diagonal entries over all configurations, Lemma 2 order\n"
      "// (0: none): a pivot D_j must exceed kMassPivotTolerance times its entry, as\n"
      "// in Step 1, where M_jj itself is at hand (docs/status.md).\n"
      "constexpr double kMassDiagonalBound[{}] = {{ {} }};\n"
      "// Status 1 when a pivot D_j is not above kMassPivotTolerance * kMassDiagonalBound[j]\n"
      "// (M not positive definite, or fewer than 6 digits left) or the pivots' spread\n"
      "// d_min / d_max is below kSpreadLimit (Step 1's digits test on the same pivots);\n"
      "// 3 for a non-finite qdd.\n"
      "int check_articulated(const double* D, const double* qdd) {{\n"
      "  for (std::int32_t j = 0; j < nv; ++j)\n"
      "    if (!(D[j] > 0.0) || !(D[j] > kMassPivotTolerance * kMassDiagonalBound[j]))\n"
      "      return not_positive_definite(j, D[j]);\n"
      "  double ratio = 0.0;\n"
      "  const std::int32_t j = jr::pivot_spread(D, nv, false, 1, kSpreadLimit, &ratio);\n"
      "  if (j >= 0)\n"
      "    return fail(kMassNotPositiveDefinite,\n"
      "                \"mass matrix singular to working precision (smallest pivot below 1e-13 of the largest)\",\n"
      "                kDofUser[j], ratio);\n"
      "  if (jr::any_non_finite(qdd, nv))\n"
      "    for (std::int32_t i = 0; i < nv; ++i)\n"
      "      if (!std::isfinite(qdd[i])) return fail(kNonFinite, \"non-finite acceleration\", i, qdd[i]);\n"
      "  g_error[0] = '\\0';\n"
      "  return kSuccess;\n"
      "}}\n",
      t.nv, fmt::join(bounds, ", "));
}

// The runtime's articulated route for trees (issue 29, item 3): after
// check_articulated (bounded = false: no bound of M_jj), the local pivot
// ratios of jr::articulated_dynamics screen for cancellation, and below
// kLocalRatioTrigger (or a pivot below kBoundTrigger of the generation-time
// bound of M_jj) the error estimate of one step of iterative refinement
// (jr::articulated_error_estimate, four more O(n) passes) decides.
std::string check_refined(const topology::Tree& t, const Options& options) {
  const std::vector<double> bounds = mass_diagonal_table(t);
  return fmt::format(
      "// Status 0 means 6 digits on this route too (docs/status.md).  A local pivot\n"
      "// ratio (jr::LocalPivotRatio: a pivot over its diagonal entry before the\n"
      "// children's projections) below kLocalRatioTrigger, cancellation in forming it,\n"
      "// has the error estimated (jr::articulated_error_estimate: the residual by\n"
      "// Newton-Euler, solved with the same factorization); an estimate above\n"
      "// kEstimateLimit gives code 1 naming the joint of the smallest ratio.  Measured\n"
      "// (docs/status.md, tests/generated/runtime_digits_test.cpp): fixed-base icub's\n"
      "// error is about 1000 eps / ratio towards its zero state, so states passing the\n"
      "// screen keep about 9 digits; long chains' ratios stay near 1e-2 and pay\n"
      "// nothing; the estimate's floor bounds eps |M| |qdd|, so it errs on the side\n"
      "// of reporting.\n"
      "// The local ratios miss a cancellation two joints away (a gimbal of two\n"
      "// nearly massless links between aligned axes): a pivot below kBoundTrigger\n"
      "// times the generation-time bound of M_jj (0: none) is screened too.\n"
      "constexpr double kLocalRatioTrigger = 1e-4;\n"
      "constexpr double kBoundTrigger = 1e-14;\n"
      "constexpr double kMassDiagonalScreen[{}] = {{ {} }};\n"
      "constexpr double kEstimateLimit = 1e-7;\n"
      "thread_local double g_refine[2 * nv];\n"
      "int check_refined(const double* v, const double* tau, const jr::LocalPivotRatio& ratio, double* qdd) {{\n"
      "  if (const int status = check_articulated(g_Dinv, qdd)) return status;\n"
      "  std::int32_t dof = ratio.min < kLocalRatioTrigger ? ratio.dof : -1;\n"
      "  double smallest = kBoundTrigger;\n"
      "  for (std::int32_t j = 0; j < nv; ++j)\n"
      "    if (g_Dinv[j] < smallest * kMassDiagonalScreen[j]) {{\n"
      "      smallest = g_Dinv[j] / kMassDiagonalScreen[j];\n"
      "      dof = j;\n"
      "    }}\n"
      "  if (dof < 0) return kSuccess;\n"
      "  const double estimate = jr::articulated_error_estimate(kModel, g_bodies, g_articulated, v, tau, g_z,\n"
      "                                                         g_refine, {}, {}, kMassDiagonalScreen);\n"
      "  if (!(estimate > kEstimateLimit)) return kSuccess;\n"
      "  return fail(kMassNotPositiveDefinite,\n"
      "              \"mass matrix nearly singular: qdd may have fewer than 6 correct digits (estimated \"\n"
      "              \"relative error above 1e-7)\",\n"
      "              kDofUser[dof], estimate);\n"
      "}}\n",
      t.nv, fmt::join(bounds, ", "), options.gravity.isZero(0.0) ? "false" : "true",
      has_damping(t) ? "true" : "false");
}

// The runtime's articulated route for closed loops (issue 29, item 3): after
// the tests of M's and W's pivots, M's local pivot ratios (as check_refined),
// its pivots against kMassDiagonalScreen and W's pivots over their diagonal
// entries screen for cancellation; a screened state has the error of qdd
// estimated from the residual of the augmented system
// (jr::articulated_closed_error_estimate).  Code 1 names the joint of M's
// screen, code 2 the row of W's, whichever is further below its trigger.
std::string check_closed(const topology::Tree& t, const Options& options) {
  const std::vector<double> bounds = mass_diagonal_table(t);
  return fmt::format(
      "// Status of jr::articulated_closed (k: -1, a dof of M, or nv + a row of W), then\n"
      "// the digits tests of M's and W's pivots as after Steps 1 and 3.4; lambda copied.\n"
      "// Status 0 means 6 digits on this route too (docs/status.md): a local pivot\n"
      "// ratio of M below kLocalRatioTrigger, a pivot of M below kBoundTrigger times\n"
      "// the generation-time bound of M_jj, or a pivot of W below kWRatioTrigger times\n"
      "// W_rr screens the state; there the error of qdd is estimated from the residual\n"
      "// of the augmented system (jr::articulated_closed_error_estimate: Newton-Euler\n"
      "// and the rows, solved with the same factorizations), and above kEstimateLimit\n"
      "// the screen furthest below its trigger is reported (code 1 naming the joint,\n"
      "// or 2 naming the loop joint and row).\n"
      "constexpr double kLocalRatioTrigger = 1e-4;\n"
      "// 1e-10, not the trees' 1e-14: the loops' forces reach a nearly singular M\n"
      "// through the rounding of Phiq (a gimbal inside a loop loses 6 digits at\n"
      "// 3e-13 of the bound, where its tree would keep them).\n"
      "constexpr double kBoundTrigger = 1e-10;\n"
      "constexpr double kWRatioTrigger = 1e-4;\n"

      "constexpr double kMassDiagonalScreen[{}] = {{ {} }};\n"
      "constexpr double kEstimateLimit = 1e-7;\n"
      "thread_local double g_refine[2 * (nv + nc)];\n"
      "int check_closed(std::int32_t k, const double* v, const double* tau, const jr::LocalPivotRatio& m_ratio,\n"
      "                 const double* qdd, double* lambda) {{\n"
      "  if (k >= nv) return constraints_singular(k - nv, g_Winv[k - nv]);\n"
      "  if (const int status = check_articulated(g_Dinv, qdd)) return status;\n"
      "  double ratio = 0.0;\n"
      "  const std::int32_t j = jr::pivot_spread(g_Winv, nc, false, 1, kSpreadLimit, &ratio);\n"
      "  if (j >= 0)\n"
      "    return fail_row(kConstraintsSingular,\n"
      "                    \"constraint rows singular to working precision (smallest pivot of T^T T below 1e-13 \"\n"
      "                    \"of the largest)\",\n"
      "                    j, ratio);\n"
      "  if (jr::any_non_finite(g_zm, nc))\n"
      "    for (std::int32_t r = 0; r < nc; ++r)\n"
      "      if (!std::isfinite(g_zm[r])) return fail_row(kNonFinite, \"non-finite multiplier\", r, g_zm[r]);\n"
      "  // The screen: how far below its trigger each test is (1: not screened).\n"
      "  std::int32_t dof = -1, row = -1;\n"
      "  double m_below = 1.0, w_below = 1.0;\n"
      "  if (m_ratio.min < kLocalRatioTrigger) {{\n"
      "    m_below = m_ratio.min / kLocalRatioTrigger;\n"
      "    dof = m_ratio.dof;\n"
      "  }}\n"
      "  for (std::int32_t i = 0; i < nv; ++i)\n"
      "    if (g_Dinv[i] < m_below * kBoundTrigger * kMassDiagonalScreen[i]) {{\n"
      "      m_below = g_Dinv[i] / (kBoundTrigger * kMassDiagonalScreen[i]);\n"
      "      dof = i;\n"
      "    }}\n"

      "  const double* W = g_closed_scratch + static_cast<std::int64_t>(nc) * nv;  // diagonal kept\n"
      "  for (std::int32_t r = 0; r < nc; ++r)\n"
      "    if (g_Winv[r] < w_below * kWRatioTrigger * W[r + nc * r]) {{\n"
      "      w_below = g_Winv[r] / (kWRatioTrigger * W[r + nc * r]);\n"
      "      row = r;\n"
      "    }}\n"
      "  if (dof >= 0 || row >= 0) {{\n"
      "    const double estimate = jr::articulated_closed_error_estimate(\n"
      "        kModel, kConstraints, g_bodies, g_articulated, g_T, g_gamma, v, tau, g_z, g_zm, g_Winv,\n"
      "        g_closed_scratch, g_refine, {}, {}, kMassDiagonalScreen);\n"
      "    if (estimate > kEstimateLimit) {{\n"
      "      if (row >= 0 && !(m_below < w_below))\n"
      "        return fail_row(kConstraintsSingular,\n"
      "                        \"constraint rows nearly singular: qdd may have fewer than 6 correct digits \"\n"
      "                        \"(estimated relative error above 1e-7)\",\n"
      "                        row, estimate);\n"
      "      return fail(kMassNotPositiveDefinite,\n"
      "                  \"mass matrix nearly singular: qdd may have fewer than 6 correct digits (estimated \"\n"
      "                  \"relative error above 1e-7)\",\n"
      "                  kDofUser[dof], estimate);\n"
      "    }}\n"
      "  }}\n"
      "  if (lambda != nullptr)\n"
      "    for (std::int32_t r = 0; r < nc; ++r) lambda[r] = g_zm[r];\n"
      "  return kSuccess;\n"
      "}}\n",
      t.nv, fmt::join(bounds, ", "), options.gravity.isZero(0.0) ? "false" : "true",
      has_damping(t) ? "true" : "false");
}

TermsBlock articulated_block(const Built& b, const topology::Tree& t) {
  TermsBlock block;
  block.route = TermsRoute::kArticulated;
  block.ops = b.emitted.block_ops;
  block.statements = b.emitted.statements;
  block.definitions =
      "// ---- forward_dynamics: specialized kinematics and articulated-body algorithm ----\n"
      "// O(n), joint frames, inertias and gravity folded in as constants.  Its pivots D\n"
      "// are those of Step 1's leaves-first L D L^T of M (eliminating a leaf dof leaves\n"
      "// the parent's articulated inertia as Schur complement: Featherstone 2008,\n"
      "// Sec. 6.5), so Step 1's tests apply to them (check_articulated).\n" +
      b.definitions + "\n" + check_articulated(t, true);
  block.fd_body =
      "  // Specialized kinematics and articulated-body algorithm: qdd in user order,\n"
      "  // the pivots D in g_Dinv (Lemma 2 order).\n"
      "  articulated_terms(q, v, tau, qdd, g_Dinv);\n"
      "  const int status = check_articulated(g_Dinv, qdd);\n";
  return block;
}

TermsBlock composite_block(const Built& b) {
  TermsBlock block;
  block.route = TermsRoute::kCompositeRigidBody;
  block.ops = b.emitted.block_ops;
  block.statements = b.emitted.statements;
  block.definitions =
      "// ---- forward_dynamics: specialized kinematics, M (eq. 14, 18) and Q = tau - h ----\n"
      "// Joint frames, inertias and gravity folded in as constants; M goes straight\n"
      "// into the packed layout that Step 1 factors in place.\n" +
      b.definitions;
  block.fd_body =
      "  // Specialized kinematics, M into g_L (packed) and Q = tau - h into g_z.\n"
      "  composite_terms(q, v, tau, g_L, g_z);\n"
      "  const int status = solve_tree(nullptr, qdd);\n";
  return block;
}

// kinematics + M (packed) + z = tau - h + packed Phiq + gamma: every term of
// eq. (17) that forward_dynamics needs, one program (kinematics shared).
Built loop_program(const topology::Tree& t, const Options& options, bool fold = true) {
  const std::string params =
      "const double* q, const double* v, const double* tau, double* L, double* z, double* T, double* gamma";
  Program program(params, "g_terms_spill");
  program.fold_identities = fold;
  program.begin_function("loop_terms_part", "forward_dynamics: specialized kinematics, M, Q = tau - h, Phiq, gamma");
  const Kinematics k = composite_blocks(program, t, options);
  program.begin_block("Phiq, gamma");
  program.comment("Phiq (packed, Lemma 3: each cut's rows touch only the dofs on its paths) and gamma.");
  const ConstraintValues c = constraint_terms(program, t, k.frames, k.motion);
  for (std::size_t i = 0; i < c.phiq_packed.size(); ++i) program.output(fmt::format("T[{}]", i), c.phiq_packed[i]);
  for (std::size_t r = 0; r < c.gamma.size(); ++r) program.output(fmt::format("gamma[{}]", r), c.gamma[r]);
  Built b{program.emit(), ""};
  b.definitions = driver(b.emitted, "loop_terms", params, "q, v, tau, L, z, T, gamma", "g_terms_spill");
  return b;
}

// Row and user column of each packed Phiq entry (analysis::cut_models'
// layout: cut by cut, kept row by kept row, the cut's dofs in order).
std::vector<std::pair<int, int>> phiq_positions(const topology::Tree& t) {
  std::vector<std::pair<int, int>> at;
  int row = 0;
  for (const topology::Cut& cut : t.cuts)
    for (std::size_t r = 0; r < cut.kept_rows.size(); ++r, ++row)
      for (int dof : cut.dofs) at.push_back({row, t.dof_user[dof]});
  return at;
}

// Operations of the runtime's routes per model, counted from its loops
// (runtime/src/runtime.cpp, articulated.cpp) for a one-dof joint: the
// articulated-body algorithm moves a 6x6 articulated inertia to the parent
// per body (two 6x6 products, about 2 * 2 * 216), the composite-rigid-body
// route builds each stored entry of M (a 6-vector carried one body up and a
// dot product, about 60) and then runs Steps 1, 2, 4.
constexpr long long kRuntimeArticulatedPerDof = 1000;
constexpr long long kRuntimeCompositePerEntry = 60;

TermsBlock runtime_block(const topology::Tree& t, const Options& options, long long solve_flops) {
  TermsBlock block;
  const long long aba = kRuntimeArticulatedPerDof * t.nv;
  const long long crb = kRuntimeCompositePerEntry * t.nnz() + solve_flops;
  // JRGEN_TERMS_ROUTE=articulated (internal, tests) takes this route whatever the count.
  const char* route = std::getenv("JRGEN_TERMS_ROUTE");
  const bool forced = route != nullptr && std::string(route) == "articulated";
  if (crb <= aba && !forced) {
    block.fd_body = runtime_fd_body(t, options);
    block.summary = fmt::format(
        "forward_dynamics: the runtime's kinematics, M and h, then Steps 1, 2, 4 (about {} operations; "
        "its articulated-body algorithm about {})",
        crb, aba);
    return block;
  }
  block.route = TermsRoute::kRuntimeArticulated;
  block.include = "#include <jrgen/articulated.hpp>\n";
  block.definitions = fmt::format(
      "// ---- forward_dynamics: the runtime's articulated-body algorithm, O(n) ----\n"
      "thread_local jr::ArticulatedState g_articulated[{}];\n{}\n{}\n{}",
      t.bodies.size(), runtime_tau_workspace(t), check_articulated(t, false), check_refined(t, options));
  std::string tau;
  const std::string forces = runtime_forces_tau(t, tau);
  block.fd_body = fmt::format(
      "  // The runtime's articulated-body algorithm (O(n)): qdd in g_z, the pivots D\n"
      "  // in g_Dinv, Lemma 2 order, and their smallest local ratio; a failed pivot\n"
      "  // stops it (check_refined).\n"
      "  jr::kinematics(kModel, g_bodies, q);\n{}"
      "  jr::LocalPivotRatio ratio;\n"
      "  jr::articulated_dynamics{}(kModel, g_bodies, g_articulated, v, {}, g_z, g_Dinv, &ratio);\n"
      "  scatter_qdd(g_z, qdd);\n"
      "  const int status = check_refined(v, {}, ratio, qdd);\n",
      forces, runtime_flags(t, options), tau, tau);
  block.summary = fmt::format(
      "forward_dynamics: the runtime's articulated-body algorithm, O(n) (about {} operations; its "
      "composite-rigid-body route and Steps 1, 2, 4 about {})",
      aba, crb);
  return block;
}

}  // namespace

long long flops(const OpCount& c) { return c.add + c.mul + c.div + c.sqrt + c.trig; }

long long terms_limit() {
  if (const char* env = std::getenv("JRGEN_TERMS_LIMIT")) return std::atoll(env);
  return kMaxTermStatements;
}

TermsBlock tree_terms(const topology::Tree& t, const Options& options, long long solve_flops) {
  const long long limit = terms_limit();
  // Programs that cannot fit are not built: the composite-rigid-body program
  // writes every stored entry of M (nnz statements at least), the
  // articulated-body program holds well over 100 statements per dof.
  const Built aba = 100LL * t.nv <= limit ? articulated_program(t, options) : Built{};
  const Built crb = t.nnz() <= limit ? composite_program(t, options) : Built{};
  const long long aba_flops = flops(aba.emitted.total), crb_flops = flops(crb.emitted.total) + solve_flops;
  const bool aba_fits = fits(aba, limit), crb_fits = fits(crb, limit);
  if (!aba_fits && !crb_fits) {
    TermsBlock block = runtime_block(t, options, solve_flops);
    block.summary += fmt::format(" (the specialized programs would hold {} and {}, the limit is {})",
                                 size_text(crb), size_text(aba), limit);
    return block;
  }
  bool articulated = aba_fits && (!crb_fits || aba_flops < crb_flops);
  // Internal, for measurements: JRGEN_TERMS_ROUTE=articulated|composite
  // forces a route that fits.
  if (const char* env = std::getenv("JRGEN_TERMS_ROUTE")) {
    if (std::string(env) == "articulated" && aba_fits) articulated = true;
    if (std::string(env) == "composite" && crb_fits) articulated = false;
  }
  TermsBlock block = articulated ? articulated_block(aba, t) : composite_block(crb);
  block.unfolded_ops = (articulated ? articulated_program(t, options, false) : composite_program(t, options, false))
                           .emitted.block_ops;
  block.summary = fmt::format(
      "forward_dynamics: {} ({} operations; the {} route counts {})",
      articulated ? "specialized kinematics and articulated-body algorithm, O(n)"
                  : "specialized kinematics, M and h, then Steps 1, 2, 4",
      articulated ? aba_flops : crb_flops, articulated ? "composite-rigid-body" : "articulated-body",
      articulated ? crb_flops : aba_flops);
  return block;
}

PieceTerms piece_terms(const topology::Tree& t, const Options& options) {
  PieceTerms pieces;
  const long long limit = terms_limit();
  if (static_cast<long long>(t.nv) * t.nv <= limit) {  // the dense M written entry by entry
    Program program("const double* q, double* M", "g_mass_spill");
    program.begin_function("mass_matrix_part", "mass_matrix(): specialized kinematics and M (eq. 14, 18)");
    program.begin_block("M");
    const std::vector<BodyFrame> frames = joint_frames(program, t);
    const std::vector<Value> Mp = mass_matrix_packed(program, t, frames);
    std::vector<Value> dense(static_cast<std::size_t>(t.nv) * t.nv, 0.0);
    for (int c = 0, k = 0; c < t.nv; ++c)
      for (int r = c; r >= 0; r = t.dof_parent[r], ++k) {
        const std::size_t ru = t.dof_user[r], cu = t.dof_user[c];
        dense[ru + t.nv * cu] = dense[cu + t.nv * ru] = Mp[k];
      }
    for (std::size_t k = 0; k < dense.size(); ++k) program.output(fmt::format("M[{}]", k), dense[k]);
    const Program::Emitted e = program.emit();
    if (e.statements <= limit && e.finite) {
      pieces.definitions += driver(e, "mass_matrix_terms", "const double* q, double* M", "q, M", "g_mass_spill");
      pieces.mass_matrix_body = "  mass_matrix_terms(q, M);  // specialized (dense, user order)\n";
    }
  }
  if (pieces.mass_matrix_body.empty())
    pieces.mass_matrix_body =
        "  jr::kinematics(kModel, g_bodies, q);\n"
        "  jr::mass_matrix_packed(kModel, g_bodies, g_L);\n"
        "  jr::unpack_mass_matrix(kModel, g_L, M);\n";
  if (100LL * t.nv <= limit) {
    Program program("const double* q, const double* v, double* h", "g_bias_spill");
    program.begin_function("bias_forces_part", "bias_forces(): specialized kinematics and h (Newton-Euler)");
    program.begin_block("h");
    const std::vector<BodyFrame> frames = joint_frames(program, t);
    const std::vector<BodyMotion6> motion = body_velocities(program, t, frames);
    const std::vector<Value> h = bias_forces(program, t, frames, motion, options.gravity);
    for (int j = 0; j < t.nv; ++j) program.output(fmt::format("h[{}]", t.dof_user[j]), h[j]);
    const Program::Emitted e = program.emit();
    if (e.statements <= limit && e.finite) {
      pieces.definitions +=
          "\n" + driver(e, "bias_forces_terms", "const double* q, const double* v, double* h", "q, v, h", "g_bias_spill");
      pieces.bias_forces_body = "  bias_forces_terms(q, v, h);  // specialized (user order)\n";
    }
  }
  if (pieces.bias_forces_body.empty())
    pieces.bias_forces_body = fmt::format(
        "  jr::kinematics(kModel, g_bodies, q);\n"
        "  jr::bias_forces{}(kModel, g_bodies, v, g_z);\n{}"
        "  for (std::int32_t j = 0; j < nv; ++j) h[kDofUser[j]] = g_z[j];\n",
        runtime_flags(t, options), runtime_forces_text(t, "g_z"));
  if (!pieces.definitions.empty())
    pieces.definitions = "// ---- mass_matrix() and bias_forces(): specialized programs ----\n" + pieces.definitions;
  return pieces;
}


TermsBlock loop_terms(const topology::Tree& t, const Options& options, long long solve_flops) {
  const long long limit = terms_limit();
  const Built b = t.nnz() <= limit && 100LL * t.nv <= limit ? loop_program(t, options) : Built{};
  TermsBlock block;
  const long long nc = t.nc();
  const long long closed = kRuntimeArticulatedPerDof * t.nv * (1 + nc / 2) + nc * nc * nc;
  const long long crb = kRuntimeCompositePerEntry * t.nnz() + solve_flops;
  // JRGEN_TERMS_ROUTE=articulated (internal, tests) takes the runtime's
  // articulated route for loops whatever the count, when the specialized
  // program does not fit (JRGEN_TERMS_LIMIT=0).
  const char* route = std::getenv("JRGEN_TERMS_ROUTE");
  const bool forced = route != nullptr && std::string(route) == "articulated";
  if (!fits(b, limit) && !options.singular_proximal && (closed < crb || forced)) {
    block.route = TermsRoute::kRuntimeArticulated;
    block.include = "#include <jrgen/articulated.hpp>\n";
    block.definitions = fmt::format(
        "// ---- forward_dynamics: the runtime's articulated-body route for closed loops ----\n"
        "// jr::articulated_closed: a0 = M^-1 (tau - h), the columns Y = M^-1 Phiq^T by\n"
        "// articulated-body solves, W = Phiq Y (Step 3.3's T^T T), W lambda = Phiq a0 - gamma,\n"
        "// qdd = a0 - Y lambda: O(n nc), no M formed.\n"
        "thread_local jr::ArticulatedState g_articulated[{}];\n"
        "thread_local double g_closed_scratch[{}];\n{}\n{}\n{}",
        t.bodies.size(), nc * (t.nv + nc), runtime_tau_workspace(t), check_articulated(t, false),
        check_closed(t, options));
    std::string tau;
    const std::string forces = runtime_forces_tau(t, tau);
    block.fd_body = fmt::format(
        "  jr::kinematics(kModel, g_bodies, q);\n{}"
        "  // Phiq (packed, Lemma 3 pattern) and gamma = -(Phiq v)_q v.\n"
        "  jr::constraint_terms(kModel, kConstraints, g_bodies, g_motion, q, v, nullptr, g_T, g_gamma);\n"
        "  // M's smallest local pivot ratio in ratio (check_closed's screen).\n"
        "  jr::LocalPivotRatio ratio;\n"
        "  const std::int32_t k = jr::articulated_closed{}(kModel, kConstraints, g_bodies, g_articulated, g_T,\n"
        "                                                g_gamma, v, {}, g_z, g_zm, g_Dinv, g_Winv,\n"
        "                                                g_closed_scratch, &ratio);\n"
        "  scatter_qdd(g_z, qdd);\n"
        "  const int status = check_closed(k, v, {}, ratio, qdd, lambda);\n",
        forces, runtime_flags(t, options), tau, tau);
    block.summary = fmt::format(
        "forward_dynamics: the runtime's kinematics, Phiq and gamma, then its articulated-body route with the "
        "columns of M^-1 Phiq^T, O(n nc) (about {} operations; M and Steps 1-4 about {}; the specialized "
        "program would hold {}, the limit is {})",
        closed, crb, size_text(b), limit);
    return block;
  }
  if (!fits(b, limit)) {
    block.fd_body = runtime_terms_text(t, options) +
                    "  // Phiq (packed, Lemma 3 pattern) and gamma = -(Phiq v)_q v.\n"
                    "  jr::constraint_terms(kModel, kConstraints, g_bodies, g_motion, q, v, nullptr, g_T, g_gamma);\n"
                    "  const int status = solve_closed(nullptr, qdd, lambda);\n";
    block.summary = fmt::format(
        "forward_dynamics: the runtime's kinematics, M, h, Phiq and gamma, then Steps 1-4 (the specialized "
        "program would hold {}, the limit is {})",
        size_text(b), limit);
    return block;
  }
  block.route = TermsRoute::kCompositeRigidBody;
  block.ops = b.emitted.block_ops;
  block.unfolded_ops = loop_program(t, options, false).emitted.block_ops;
  block.statements = b.emitted.statements;
  block.definitions =
      "// ---- forward_dynamics: specialized kinematics, M, Q = tau - h, Phiq and gamma ----\n"
      "// Joint frames, inertias, cut frames and gravity folded in as constants, the\n"
      "// kinematics computed once for all terms; M and Phiq go straight into the\n"
      "// packed layouts that Steps 1 and 3 read.\n" +
      b.definitions;
  block.fd_body =
      "  // Specialized terms: M into g_L (packed), Q = tau - h into g_z, Phiq into g_T\n"
      "  // (packed, Lemma 3 pattern), gamma = -(Phiq v)_q v into g_gamma.\n"
      "  loop_terms(q, v, tau, g_L, g_z, g_T, g_gamma);\n"
      "  const int status = solve_closed(nullptr, qdd, lambda);\n";
  block.summary = fmt::format(
      "forward_dynamics: specialized kinematics, M, h, Phiq and gamma ({} operations), then Steps 1-4",
      flops(b.emitted.total));
  return block;
}

ConstraintPieces constraint_pieces(const topology::Tree& t) {
  ConstraintPieces pieces;
  const long long limit = terms_limit();
  const int nc = t.nc();
  const std::vector<std::pair<int, int>> at = phiq_positions(t);
  // One program per piece: constraints(q, phi), constraint_jacobian(q, Phiq)
  // dense column-major (zeros written), constraint_gamma(q, v, gamma).
  auto build = [&](const std::string& name, const std::string& params, const std::string& args, int which) {
    if (100LL * t.nv > limit || (which == 1 && static_cast<long long>(nc) * t.nv > limit)) return false;
    Program program(params, "g_" + name + "_spill");
    program.begin_function(name + "_part", name + "(): specialized kinematics and constraint terms");
    program.begin_block(name);
    const std::vector<BodyFrame> frames = joint_frames(program, t);
    std::vector<BodyMotion6> motion;
    if (which == 2) motion = body_velocities(program, t, frames);
    const ConstraintValues c = constraint_terms(program, t, frames, motion);
    if (which == 0)
      for (int r = 0; r < nc; ++r) program.output(fmt::format("phi[{}]", r), c.phi[r]);
    if (which == 1) {
      std::vector<Value> dense(static_cast<std::size_t>(nc) * t.nv, 0.0);
      for (std::size_t k = 0; k < at.size(); ++k)
        if (!c.phiq_packed[k].is(0.0)) dense[at[k].first + static_cast<std::size_t>(nc) * at[k].second] = c.phiq_packed[k];
      for (std::size_t k = 0; k < dense.size(); ++k) program.output(fmt::format("Phiq[{}]", k), dense[k]);
    }
    if (which == 2)
      for (int r = 0; r < nc; ++r) program.output(fmt::format("gamma[{}]", r), c.gamma[r]);
    const Program::Emitted e = program.emit();
    if (e.statements > limit || !e.finite) return false;
    pieces.definitions += "\n" + driver(e, name + "_terms", params, args, "g_" + name + "_spill");
    return true;
  };
  pieces.constraints_body = build("constraints", "const double* q, double* phi", "q, phi", 0)
                                ? "  constraints_terms(q, phi);  // specialized\n"
                                : "  jr::constraints(kModel, kConstraints, g_bodies, q, phi);\n";
  pieces.jacobian_body =
      build("constraint_jacobian", "const double* q, double* Phiq", "q, Phiq", 1)
          ? "  constraint_jacobian_terms(q, Phiq);  // specialized (dense, column-major)\n"
          : "  jr::kinematics(kModel, g_bodies, q);\n"
            "  jr::constraint_terms(kModel, kConstraints, g_bodies, g_motion, q, nullptr, nullptr, g_T, nullptr);\n"
            "  jr::unpack_constraint_jacobian(kModel, kConstraints, g_T, Phiq);\n";
  pieces.gamma_body =
      build("constraint_gamma", "const double* q, const double* v, double* gamma", "q, v, gamma", 2)
          ? "  constraint_gamma_terms(q, v, gamma);  // specialized\n"
          : "  jr::kinematics(kModel, g_bodies, q);\n"
            "  jr::constraint_terms(kModel, kConstraints, g_bodies, g_motion, q, v, nullptr, nullptr, gamma);\n";
  if (!pieces.definitions.empty())
    pieces.definitions = "// ---- constraints(), constraint_jacobian(), constraint_gamma(): specialized ----" +
                         pieces.definitions;
  return pieces;
}

}  // namespace jrgen::emit
