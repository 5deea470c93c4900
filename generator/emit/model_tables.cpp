// The constant tables of the model in the generated solver (kBodies, the dof
// tree, the joint names and indices, jr::Model's initializer, the cut joints
// kCuts and their rows' labels) and the picture of L's pattern in its
// banner: the data the runtime's kinematics, dynamics and constraint terms
// read (Section 4.3, Step 0).
#include <fmt/format.h>

#include <string>
#include <vector>

#include "analysis/runtime_model.hpp"
#include "emit/blocks.hpp"
#include "emit/format.hpp"
#include "emit/steps/step3.hpp"

namespace jrgen::emit {

namespace {

const char* joint_kind(ir::JointType type) {
  switch (type) {
    case ir::JointType::Revolute:
    case ir::JointType::Continuous: return "jr::JointKind::kRevolute";
    case ir::JointType::Prismatic: return "jr::JointKind::kPrismatic";
    case ir::JointType::Ball: return "jr::JointKind::kBall";
    case ir::JointType::Floating: return "jr::JointKind::kFloating";
    case ir::JointType::Planar: return "jr::JointKind::kPlanar";
    case ir::JointType::Fixed: break;
  }
  return "?";
}

const char* cut_kind(ir::CutType type) {
  switch (type) {
    case ir::CutType::Spherical: return "jr::CutKind::kSpherical";
    case ir::CutType::Revolute: return "jr::CutKind::kRevolute";
    case ir::CutType::Prismatic: return "jr::CutKind::kPrismatic";
    case ir::CutType::Cylindrical: return "jr::CutKind::kCylindrical";
    case ir::CutType::Universal: return "jr::CutKind::kUniversal";
    case ir::CutType::Fixed: return "jr::CutKind::kFixed";
    case ir::CutType::Distance: return "jr::CutKind::kDistance";
    case ir::CutType::Mimic: return "jr::CutKind::kMimic";
  }
  return "?";
}

// ASCII picture of the block pattern of L (rows: Lemma 2 order), for models
// small enough to read it.
std::string pattern_comment(const topology::Tree& t) {
  constexpr int kMaxPictured = 64;
  if (t.nv > kMaxPictured) return fmt::format("//\n// Pattern of L not drawn (nv = {} > {}).", t.nv, kMaxPictured);
  std::vector<std::string> rows(t.nv, std::string(t.nv, ' '));
  for (int c = 0; c < t.nv; ++c) {
    for (int r = c + 1; r < t.nv; ++r) rows[r][c] = '.';
    rows[c][c] = 'x';
    for (int r : t.ancestors(c)) rows[r][c] = 'x';
  }
  std::string out = "//\n// Pattern of L (x: computed, .: structurally zero, never touched):\n";
  for (int r = 0; r < t.nv; ++r) {
    std::string row = rows[r];
    row.erase(row.find_last_not_of(' ') + 1);
    out += fmt::format("//   {:>4} {}  {}\n", r, row, comment_text(t.bodies[t.dof_body[r]].joint_name));
  }
  out.pop_back();
  return out;
}

std::string body_tables(const topology::Tree& t) {
  std::string out;
  for (std::size_t b = 0; b < t.bodies.size(); ++b) {
    const topology::Body& body = t.bodies[b];
    const Eigen::Matrix3d& R = body.X_PJ.R;
    const Eigen::Matrix3d& I = body.inertial.I_com;
    out += fmt::format("// {}: joint '{}' ({}), parent {}\n", b, comment_text(body.joint_name),
                       ir::joint_type_name(body.type),
                       body.parent_lem >= 0 ? std::to_string(body.parent_lem) : "base");
    out += fmt::format(
        "{{{}, {}, {}, {}, {}, {}, {},\n"
        " {{{}, {}, {}, {}, {}, {}, {}, {}, {}}},\n"
        " {}, {}, {}, {},\n"
        " {}, {}, {{{}, {}, {}, {}, {}, {}}}, {}}},\n",
        c_string(body.joint_name), joint_kind(body.type), body.parent_lem, body.q_user, body.v_user, body.v_lem,
        body.nv, num(R(0, 0)), num(R(0, 1)), num(R(0, 2)), num(R(1, 0)), num(R(1, 1)), num(R(1, 2)),
        num(R(2, 0)), num(R(2, 1)), num(R(2, 2)), vec(body.X_PJ.p), vec(body.axis), vec(body.e1),
        vec(body.e2), num(body.inertial.mass), vec(body.inertial.com), num(I(0, 0)), num(I(1, 1)),
        num(I(2, 2)), num(I(0, 1)), num(I(0, 2)), num(I(1, 2)), num(body.damping));
  }
  out.pop_back();
  return out;
}

// q_assembled[]: the configuration jrgen assembled the loops at, or the zero
// configuration (identity quaternions) of a tree; 17 significant digits.
std::string assembled_values(const topology::Tree& t, const Options& options) {
  std::vector<double> q = options.q_assembled;
  if (q.empty()) {
    q.assign(t.nq, 0.0);
    for (const topology::Body& b : t.bodies) {
      if (b.type == ir::JointType::Ball) q[b.q_user] = 1.0;
      if (b.type == ir::JointType::Floating) q[b.q_user + 3] = 1.0;
    }
  }
  std::string out;
  for (std::size_t i = 0; i < q.size(); ++i) out += fmt::format("{}{:.17g}", i ? ", " : "", q[i]);
  return out;
}

// kForces (docs/interface.md section 2b: springs, joint springs, joint forces) for
// the runtime's force_elements() and potential_energy(); nothing for a model
// without them (forces_ptr: nullptr).
void force_tables(const topology::Tree& t, TemplateValues& v) {
  const std::vector<jr::SpringModel> springs = analysis::spring_models(t);
  const std::vector<jr::JointForceModel> joints = analysis::joint_force_models(t);
  v["forces_ptr"] = springs.empty() && joints.empty() ? "nullptr" : "&kForces";
  v["force_tables"] = "";
  if (springs.empty() && joints.empty()) return;
  auto v3 = [](const double* p) { return fmt::format("{{{}, {}, {}}}", num(p[0]), num(p[1]), num(p[2])); };
  std::string s = "\n// ---- Force elements (springs, joint springs, joint forces) -------------------\n";
  std::string spring_array = "nullptr", joint_array = "nullptr";
  if (!springs.empty()) {
    s += "// Per spring: name, body k, body l, point on k, point on l (body frames),\n"
         "// stiffness, damping, rest length.\n";
    s += fmt::format("constexpr jr::SpringModel kSprings[{}] = {{\n", springs.size());
    for (const jr::SpringModel& m : springs)
      s += fmt::format("{{{}, {}, {}, {}, {}, {}, {}, {}}},\n", c_string(m.name), m.body_k, m.body_l, v3(m.p_k),
                       v3(m.p_l), num(m.stiffness), num(m.damping), num(m.rest_length));
    s += "};\n";
    spring_array = "kSprings";
  }
  if (!joints.empty()) {
    s += "// Per one-dof joint: body, joint spring stiffness and rest, joint force.\n";
    s += fmt::format("constexpr jr::JointForceModel kJointForces[{}] = {{\n", joints.size());
    for (const jr::JointForceModel& m : joints)
      s += fmt::format("{{{}, {}, {}, {}}},  // '{}'\n", m.body, num(m.stiffness), num(m.rest), num(m.force),
                       comment_text(t.bodies[m.body].joint_name));
    s += "};\n";
    joint_array = "kJointForces";
  }
  s += fmt::format("constexpr jr::ForceModel kForces = {{{}, {}, {}, {}}};", springs.size(), spring_array,
                   joints.size(), joint_array);
  v["force_tables"] = s;
}

}  // namespace

void model_tables(const topology::Tree& t, const Options& options, TemplateValues& v) {
  const int nb = static_cast<int>(t.bodies.size());
  v["pattern"] = pattern_comment(t);
  std::string names, q_index, v_index;
  std::vector<int> dof_joint(t.nv, 0);
  for (int ju = 0; ju < nb; ++ju) {
    const topology::Body& b = t.bodies[t.body_of_user_joint[ju]];
    names += c_string(b.joint_name) + ",\n";
    q_index += std::string(ju ? ", " : "") + std::to_string(b.q_user);
    v_index += std::string(ju ? ", " : "") + std::to_string(b.v_user);
    for (int k = 0; k < b.nv; ++k) dof_joint[b.v_user + k] = ju;
  }
  names.pop_back();
  v["joint_names"] = names;
  v["joint_q_index"] = q_index;
  v["joint_v_index"] = v_index;
  v["q_assembled"] = assembled_values(t, options);
  v["bodies"] = body_tables(t);
  v["dof_parent"] = join_ints(t.dof_parent);
  v["dof_user"] = join_ints(t.dof_user);
  v["col_start"] = join_ints(t.M_col_start);
  v["dof_joint"] = join_ints(dof_joint);
  force_tables(t, v);
  v["model_init"] = fmt::format("{}, {}, {}, kBodies, kDofParent, kDofUser, kMColStart, {{{}, {}, {}}}", nb, t.nq, t.nv,
                                num(options.gravity[0]), num(options.gravity[1]), num(options.gravity[2]));
}

std::string constraint_tables(const topology::Tree& t, const std::vector<Row>& rows) {
  const std::vector<jr::CutModel> models = analysis::cut_models(t);
  const int m = static_cast<int>(rows.size());
  const int phiq_nnz = rows.empty() ? 0 : rows.back().t_start + static_cast<int>(t.cuts[rows.back().cut].dofs.size());
  std::string s = "// ---- Cut joints (closed loops) -----------------------------------------------\n";
  s += "// Per cut: name, kind, body k, body l, frame on k (R row-major, p), frame on l,\n"
       "// axis, child axis, distance, kept-row mask, first row, packed Phiq start, dofs per row.\n";
  s += fmt::format("constexpr jr::CutModel kCuts[{}] = {{\n", t.cuts.size());
  auto mat = [](const double* R) {
    return fmt::format("{{{}, {}, {}, {}, {}, {}, {}, {}, {}}}", num(R[0]), num(R[1]), num(R[2]), num(R[3]),
                       num(R[4]), num(R[5]), num(R[6]), num(R[7]), num(R[8]));
  };
  auto v3 = [](const double* p) { return fmt::format("{{{}, {}, {}}}", num(p[0]), num(p[1]), num(p[2])); };
  for (std::size_t c = 0; c < t.cuts.size(); ++c) {
    const topology::Cut& cut = t.cuts[c];
    const jr::CutModel& cm = models[c];
    std::string kept;
    for (int r : cut.kept_rows) kept += fmt::format("{}{}", kept.empty() ? "" : ", ", r + 1);
    s += fmt::format("// {}: loop joint '{}' ({}), bodies {} and {}, rows kept: {}\n", c, comment_text(cut.name),
                     ir::cut_type_name(cut.type), cut.body_k, cut.body_l, kept.empty() ? "none" : kept);
    s += fmt::format("{{{}, {}, {}, {},\n {}, {},\n {}, {},\n {}, {}, {}, {}, {}, {}, {}}},\n", c_string(cut.name),
                     cut_kind(cut.type), cm.body_k, cm.body_l, mat(cm.R_k), v3(cm.p_k), mat(cm.R_l), v3(cm.p_l),
                     v3(cm.axis), v3(cm.child_axis), num(cm.distance), cm.row_mask, cm.first_row, cm.phiq_start,
                     cm.num_dofs);
  }
  s += "};\n";
  // [[maybe_unused]]: only the runtime's terms (large models) read it, not the specialized ones.
  s += fmt::format("[[maybe_unused]] constexpr jr::ConstraintModel kConstraints = {{{}, {}, {}, kCuts}};\n",
                   t.cuts.size(), m, phiq_nnz);
  s += "// Kept constraint row -> the loop joint and row of its type (for diagnostics).\n";
  s += fmt::format("const char* const kRowLabel[{}] = {{\n", m);
  for (int g = 0; g < m; ++g) {
    const topology::Cut& cut = t.cuts[rows[g].cut];
    s += c_string(cut.type == ir::CutType::Mimic
                      ? fmt::format("mimic joint '{}' (its <mimic> row)", cut.name)
                      : fmt::format("loop joint '{}' row {} of {} ({})", cut.name, rows[g].type_row + 1, cut.rows,
                                    ir::cut_type_name(cut.type))) +
         ",\n";
  }
  return s + "};";
}

}  // namespace jrgen::emit
