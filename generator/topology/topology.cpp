#include "topology/topology.hpp"

#include <algorithm>
#include <iterator>
#include <queue>
#include <stdexcept>

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "ir/error.hpp"

namespace jrgen::topology {

namespace {

// Mass properties accumulated about a body origin: m, first moment m c and
// rotational inertia about the origin, all in body coordinates.
struct MassAccumulator {
  double m = 0.0;
  Eigen::Vector3d h = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I_o = Eigen::Matrix3d::Zero();

  // Adds a link's inertial placed at X_BL.
  void add(const ir::Inertial& in, const ir::Pose& X_BL) {
    const Eigen::Matrix3d Ic = X_BL.R * in.I_com * X_BL.R.transpose();
    if (in.mass == 0.0) {  // no 0 x distance^2 terms: NaN for a link placed far out
      I_o += Ic;
      return;
    }
    const Eigen::Vector3d c = X_BL.p + X_BL.R * in.com;
    m += in.mass;
    h += in.mass * c;
    I_o += Ic + in.mass * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  }

  ir::Inertial to_inertial() const {
    ir::Inertial out;
    out.mass = m;
    out.com = m > 0.0 ? Eigen::Vector3d(h / m) : Eigen::Vector3d::Zero();
    out.I_com = I_o - m * (out.com.squaredNorm() * Eigen::Matrix3d::Identity() -
                           out.com * out.com.transpose());
    // As 0.5 (A + A^T), without overflow; eval(): the right side reads A^T
    // while the left is written (Eigen's transpose aliasing).
    out.I_com = (0.5 * out.I_com + 0.5 * out.I_com.transpose()).eval();
    return out;
  }
};

// Entries below the rounding of their quantity, set to zero: |x| <= u max|x|
// with u = 2^-53, the unit roundoff.  URDF exporters write such residues
// ("0 1 6.12323e-17" for an axis, rpy 1.11022e-16): they perturb every
// product they enter by less than its own rounding error (|a . x - a' . x| <=
// u |a| |x|, the bound of the dot product itself), but they turn an
// axis-aligned joint or an identity rotation into a general one, which costs
// the specialized code its folding (emit/kinematics.cpp, docs/specialization.md).
template <typename Derived>
void snap_rounding_residues(Eigen::MatrixBase<Derived>& x, double scale) {
  const double below = std::ldexp(scale, -53);
  if (!std::isfinite(below)) return;  // an overflowing quantity is reported, not snapped
  for (Eigen::Index i = 0; i < x.size(); ++i)
    if (std::abs(x(i)) <= below) x(i) = 0.0;
}

void snap_rounding_residues(ir::Pose& X) {
  snap_rounding_residues(X.R, 1.0);  // orthonormal: every entry's scale is 1
  snap_rounding_residues(X.p, X.p.cwiseAbs().maxCoeff());
}

void snap_rounding_residues(ir::Inertial& in) {
  snap_rounding_residues(in.com, in.com.cwiseAbs().maxCoeff());
  snap_rounding_residues(in.I_com, in.I_com.cwiseAbs().maxCoeff());
}

// Planar in-plane directions, cyclic from the normal (docs/interface.md section 3).
void planar_directions(const Eigen::Vector3d& n, Eigen::Vector3d& e1, Eigen::Vector3d& e2) {
  int axis = 0;
  n.cwiseAbs().maxCoeff(&axis);
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  e1 = Eigen::Vector3d::Unit(a1);
  e2 = Eigen::Vector3d::Unit(a2);  // for a negative normal too, as docs/interface.md states it
}

bool is_finite(const ir::Pose& X) { return X.R.allFinite() && X.p.allFinite(); }

bool is_finite(const ir::Inertial& in) {
  return std::isfinite(in.mass) && in.com.allFinite() && in.I_com.allFinite();
}

// Raises `in` to the bounds (--bound-mass, --bound-inertia): the mass to
// bounds.mass, and each principal moment about the centre of mass below
// bounds.inertia to it, about the same principal axes.  Returns what changed,
// "" when nothing did (then `in` is untouched, bit for bit).
std::string raise_to_bounds(ir::Inertial& in, const MassBounds& bounds) {
  std::string what;
  if (bounds.mass > 0.0 && in.mass < bounds.mass) {
    what = fmt::format("mass {:g} kg raised to {:g} (--bound-mass)", in.mass, bounds.mass);
    in.mass = bounds.mass;
  }
  if (!(bounds.inertia > 0.0)) return what;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(in.I_com);
  Eigen::Vector3d moments = eig.eigenvalues();
  if (moments.minCoeff() < bounds.inertia) {
    what += fmt::format("{}principal moments of inertia ({:g}, {:g}, {:g}) kg m^2 raised to at least {:g} "
                        "(--bound-inertia)",
                        what.empty() ? "" : "; ", moments[0], moments[1], moments[2], bounds.inertia);
    moments = moments.cwiseMax(bounds.inertia);
    const Eigen::Matrix3d& V = eig.eigenvectors();
    in.I_com = V * moments.asDiagonal() * V.transpose();
    in.I_com = (0.5 * (in.I_com + in.I_com.transpose())).eval();  // eval(): transpose aliasing
  }
  return what;
}

// Every constant the emitter prints for a body must be finite (docs/interface.md
// section 1): names the joint whose frame overflows, or the link whose
// inertial does (else the joint carrying links whose fused sum does).
void check_finite_body(const ir::Robot& robot, const Body& body, const std::vector<LinkPlacement>& links) {
  const ir::Joint& joint = robot.joints[body.joint_ir];
  if (!is_finite(body.X_PJ))
    throw Error(joint.where, "joint", joint.name,
                "its frame in the parent body (this <origin> composed with the fixed joints above it) overflows "
                "double precision; check the <origin> values (metres, radians)");
  if (is_finite(body.inertial)) return;
  for (int l : body.links) {
    MassAccumulator one;
    one.add(robot.links[l].inertial, links[l].X_BL);
    if (!is_finite(one.to_inertial()))
      throw Error(robot.links[l].where, "link", robot.links[l].name,
                  fmt::format("its <inertial>, placed on the body moved by joint '{}', overflows double precision "
                              "(mass, inertia or mass x distance^2); check <mass>, <inertia> and <origin> (SI units)",
                              joint.name));
  }
  throw Error(joint.where, "joint", joint.name,
              "the mass properties of the links it moves, fused through fixed joints, overflow double precision "
              "when added; check their <mass>, <inertia> and <origin> (SI units)");
}

}  // namespace

ir::Pose compose(const ir::Pose& X_AB, const ir::Pose& X_BC) {
  ir::Pose X_AC;
  X_AC.R = X_AB.R * X_BC.R;
  X_AC.p = X_AB.p + X_AB.R * X_BC.p;
  return X_AC;
}

std::vector<int> Tree::ancestors(int dof_lem) const {
  std::vector<int> out;
  for (int r = dof_parent[dof_lem]; r >= 0; r = dof_parent[r]) out.push_back(r);
  return out;
}

std::vector<std::vector<int>> Tree::descendants() const {
  std::vector<std::vector<int>> out(nv);
  for (int i = 0; i < nv; ++i)
    for (int r = dof_parent[i]; r >= 0; r = dof_parent[r]) out[r].push_back(i);
  return out;
}

Tree build_tree(const ir::Robot& robot, const MassBounds& bounds) {
  Tree tree;
  const int num_links = static_cast<int>(robot.links.size());
  tree.links.assign(num_links, LinkPlacement{});

  // 1. Fuse fixed joints, creating bodies in user order (joints are stored
  //    depth-first, so a joint's parent link is always placed already).
  std::vector<Body> user_bodies;
  std::vector<MassAccumulator> mass;
  std::vector<bool> placed(num_links, false);
  placed[robot.root_link] = true;
  int q_user = 0, v_user = 0;
  for (int j = 0; j < static_cast<int>(robot.joints.size()); ++j) {
    const ir::Joint& joint = robot.joints[j];
    if (!placed[joint.parent_link])
      throw std::logic_error("joints not in depth-first order at joint " + joint.name);
    const LinkPlacement& parent = tree.links[joint.parent_link];
    LinkPlacement& child = tree.links[joint.child_link];
    placed[joint.child_link] = true;
    if (joint.type == ir::JointType::Fixed) {
      child.body_lem = parent.body_lem;  // still a user index; relabelled below
      child.X_BL = compose(parent.X_BL, joint.origin);
    } else {
      Body body;
      body.joint_name = joint.name;
      body.type = joint.type;
      body.joint_ir = j;
      body.joint_user = static_cast<int>(user_bodies.size());
      body.parent_lem = parent.body_lem;
      body.nq = ir::joint_nq(joint.type);
      body.nv = ir::joint_nv(joint.type);
      body.q_user = q_user;
      body.v_user = v_user;
      q_user += body.nq;
      v_user += body.nv;
      body.X_PJ = compose(parent.X_BL, joint.origin);
      body.axis = joint.axis;
      snap_rounding_residues(body.X_PJ);
      snap_rounding_residues(body.axis, 1.0);
      if (joint.type == ir::JointType::Planar) planar_directions(joint.axis, body.e1, body.e2);
      body.damping = joint.damping;
      child.body_lem = body.joint_user;
      child.X_BL = ir::Pose{};
      user_bodies.push_back(body);
      mass.emplace_back();
    }
    if (child.body_lem >= 0) {
      mass[child.body_lem].add(robot.links[joint.child_link].inertial, child.X_BL);
      user_bodies[child.body_lem].links.push_back(joint.child_link);
    }
  }
  tree.nq = q_user;
  tree.nv = v_user;
  const int nb = static_cast<int>(user_bodies.size());
  for (int b = 0; b < nb; ++b) {
    Body& body = user_bodies[b];
    body.inertial = mass[b].to_inertial();
    snap_rounding_residues(body.inertial);
    check_finite_body(robot, body, tree.links);
    const std::string raised = raise_to_bounds(body.inertial, bounds);
    if (!raised.empty()) {
      const ir::Joint& joint = robot.joints[body.joint_ir];
      tree.notes.push_back(Error(joint.where, "joint", joint.name, "the body it moves: " + raised).what());
    }
  }

  // A moving body whose whole subtree carries no mass makes a zero row in M.
  {
    std::vector<double> subtree_mass(nb, 0.0), subtree_inertia(nb, 0.0);
    for (int b = nb - 1; b >= 0; --b) {  // preorder reversed: children first
      subtree_mass[b] += user_bodies[b].inertial.mass;
      subtree_inertia[b] += user_bodies[b].inertial.I_com.trace();
      if (user_bodies[b].parent_lem >= 0) {
        subtree_mass[user_bodies[b].parent_lem] += subtree_mass[b];
        subtree_inertia[user_bodies[b].parent_lem] += subtree_inertia[b];
      }
    }
    for (int b = 0; b < nb; ++b)
      if (!(subtree_mass[b] > 0.0) && !(subtree_inertia[b] > 0.0)) {
        const ir::Joint& joint = robot.joints[user_bodies[b].joint_ir];
        throw Error(joint.where, "joint", joint.name,
                    "moves no mass (every link it carries has zero mass and inertia), so the "
                    "mass matrix is singular; give the child link an <inertial>, or load with "
                    "--bound-mass KG --bound-inertia KGM2 (as MuJoCo's boundmass, boundinertia)");
      }
  }

  // 2. Lemma 2 renumbering: post-order (children in user order, then the
  //    parent), so every descendant precedes its ancestors.
  std::vector<std::vector<int>> children(nb);
  std::vector<int> roots;
  for (int b = 0; b < nb; ++b) {
    if (user_bodies[b].parent_lem >= 0) children[user_bodies[b].parent_lem].push_back(b);
    else roots.push_back(b);
  }
  std::vector<int> lem_of_user(nb, -1), order;
  order.reserve(nb);
  // Iterative post-order (deep chains must not overflow the stack).
  std::vector<std::pair<int, std::size_t>> stack;
  for (int root : roots) {
    stack.emplace_back(root, 0);
    while (!stack.empty()) {
      auto& [b, next] = stack.back();
      if (next < children[b].size()) {
        const int c = children[b][next++];
        stack.emplace_back(c, 0);
      } else {
        lem_of_user[b] = static_cast<int>(order.size());
        order.push_back(b);
        stack.pop_back();
      }
    }
  }
  tree.bodies.resize(nb);
  tree.body_of_user_joint = lem_of_user;
  for (int b = 0; b < nb; ++b) {
    Body body = user_bodies[b];
    body.parent_lem = body.parent_lem >= 0 ? lem_of_user[body.parent_lem] : -1;
    for (int c : children[b]) body.children_lem.push_back(lem_of_user[c]);
    tree.bodies[lem_of_user[b]] = body;
  }
  for (LinkPlacement& lp : tree.links)
    if (lp.body_lem >= 0) lp.body_lem = lem_of_user[lp.body_lem];

  // 3. Dof-level structure.  Within a joint the dofs form a chain (the
  //    diagonal block is dense); a joint's last dof hangs below the parent
  //    joint's first dof.
  tree.dof_parent.assign(tree.nv, -1);
  tree.dof_body.assign(tree.nv, -1);
  tree.dof_user.assign(tree.nv, -1);
  tree.dof_depth.assign(tree.nv, 0);
  int v_lem = 0;
  for (int b = 0; b < nb; ++b) {
    tree.bodies[b].v_lem = v_lem;
    v_lem += tree.bodies[b].nv;
  }
  for (int b = 0; b < nb; ++b) {
    const Body& body = tree.bodies[b];
    for (int k = 0; k < body.nv; ++k) {
      const int d = body.v_lem + k;
      tree.dof_body[d] = b;
      tree.dof_user[d] = body.v_user + k;
      if (k + 1 < body.nv) tree.dof_parent[d] = d + 1;
      else if (body.parent_lem >= 0) tree.dof_parent[d] = tree.bodies[body.parent_lem].v_lem;
    }
  }
  for (int d = tree.nv - 1; d >= 0; --d)  // parents have larger indices
    tree.dof_depth[d] = tree.dof_parent[d] >= 0 ? tree.dof_depth[tree.dof_parent[d]] + 1 : 0;
  tree.M_col_start.assign(tree.nv + 1, 0);
  for (int d = 0; d < tree.nv; ++d) tree.M_col_start[d + 1] = tree.M_col_start[d] + tree.dof_depth[d] + 1;

  // 4. Cut joints: the bodies they join and the dofs of Lemma 3.
  for (int c = 0; c < static_cast<int>(robot.cuts.size()); ++c) {
    const ir::CutJoint& ic = robot.cuts[c];
    Cut cut;
    cut.name = ic.name;
    cut.type = ic.type;
    cut.cut_ir = c;
    const LinkPlacement& k = tree.links[ic.link_k];
    const LinkPlacement& l = tree.links[ic.link_l];
    cut.body_k = k.body_lem;
    cut.body_l = l.body_lem;
    cut.X_BkF = compose(k.X_BL, ic.frame_k);
    cut.X_BlF = compose(l.X_BL, ic.frame_l);
    cut.axis = ic.axis;
    cut.child_axis = ic.child_axis;
    snap_rounding_residues(cut.X_BkF);
    snap_rounding_residues(cut.X_BlF);
    snap_rounding_residues(cut.axis, 1.0);
    snap_rounding_residues(cut.child_axis, 1.0);
    cut.distance = ic.distance;
    cut.distance_given = ic.distance_given;
    if (!is_finite(cut.X_BkF) || !is_finite(cut.X_BlF))
      throw Error(ic.where, "loop_joint", ic.name,
                  "its joint frames, composed with the fixed joints of their links, overflow double precision; "
                  "check <origin> and <child_origin> (metres, radians)");
    if (cut.body_k == cut.body_l)
      throw Error(ic.where, "loop_joint", ic.name,
                  "joins two links of the same rigid body (after fusing fixed joints); it constrains nothing: remove it, or "
                  "correct its <parent> or <child> link");
    int dk = cut.body_k >= 0 ? tree.bodies[cut.body_k].v_lem : -1;
    int dl = cut.body_l >= 0 ? tree.bodies[cut.body_l].v_lem : -1;
    while (dk >= 0 || dl >= 0) {  // merge of two increasing chains
      const int d = dl < 0 ? dk : dk < 0 ? dl : std::min(dk, dl);
      cut.dofs.push_back(d);
      if (dk != dl) cut.num_distinct = static_cast<int>(cut.dofs.size());
      if (dk == d) dk = tree.dof_parent[dk];
      if (dl == d) dl = tree.dof_parent[dl];
    }
    cut.rows = ir::cut_rows(ic.type);
    for (int r = 0; r < cut.rows; ++r) cut.kept_rows.push_back(r);
    if (ic.type == ir::CutType::Mimic) {
      cut.num_distinct = static_cast<int>(cut.dofs.size());
      cut.multiplier = ic.multiplier;
      cut.offset = ic.offset;
    }
    tree.cuts.push_back(std::move(cut));
  }
  place_force_elements(robot, tree);

  check_lemma2(tree);
  return tree;
}

int Tree::nc() const {
  int n = 0;
  for (const Cut& c : cuts) n += static_cast<int>(c.kept_rows.size());
  return n;
}

std::vector<Supernode> dense_supernodes(const Tree& tree, int min_size) {
  std::vector<int> num_children(tree.nv, 0);
  for (int d = 0; d < tree.nv; ++d)
    if (tree.dof_parent[d] >= 0) ++num_children[tree.dof_parent[d]];
  std::vector<Supernode> out;
  long long offset = 0;
  for (int j = 0; j < tree.nv;) {
    int last = j;
    while (tree.dof_parent[last] == last + 1 && num_children[last + 1] == 1) ++last;
    const int size = last - j + 1;
    if (size >= min_size) {
      Supernode sn;
      sn.first = j;
      sn.size = size;
      sn.rows = size + tree.dof_depth[last];
      sn.offset = offset;
      offset += static_cast<long long>(sn.rows) * size;
      out.push_back(sn);
    }
    j = last + 1;
  }
  return out;
}

std::vector<Subtree> partition_subtrees(const Tree& tree, int parts, int max_separator) {
  const int nv = tree.nv;
  std::vector<long long> work(nv, 0);
  std::vector<int> size(nv, 1);
  std::vector<std::vector<int>> children(nv);
  std::vector<int> roots;
  long long total = 0;
  for (int d = 0; d < nv; ++d) {  // children before parents (Lemma 2)
    const long long k = tree.dof_depth[d] + 1;
    work[d] += k * k;
    total += k * k;
    const int p = tree.dof_parent[d];
    if (p >= 0) {
      work[p] += work[d];
      size[p] += size[d];
      children[p].push_back(d);
    } else {
      roots.push_back(d);
    }
  }
  std::priority_queue<std::pair<long long, int>> candidates;
  for (int r : roots) candidates.push({work[r], r});
  const long long limit = total / std::max(parts, 1);
  int separator = 0;
  while (!candidates.empty() && candidates.top().first > limit && separator < max_separator) {
    const int r = candidates.top().second;
    candidates.pop();
    ++separator;
    for (int c : children[r]) candidates.push({work[c], c});
  }
  std::vector<Subtree> out;
  while (!candidates.empty()) {
    const int r = candidates.top().second;
    candidates.pop();
    Subtree t;
    t.first = r - size[r] + 1;
    t.root = r;
    t.path = tree.dof_depth[r];
    t.work = work[r];
    out.push_back(t);
  }
  std::sort(out.begin(), out.end(), [](const Subtree& a, const Subtree& b) { return a.first < b.first; });
  long long buffer = 0;
  for (Subtree& t : out) {
    t.buffer = buffer;
    buffer += static_cast<long long>(t.path) * t.path;
  }
  return out;
}

void check_lemma2(const Tree& tree) {
  const int nb = static_cast<int>(tree.bodies.size());
  for (int b = 0; b < nb; ++b) {
    const Body& body = tree.bodies[b];
    if (body.parent_lem >= 0 && body.parent_lem <= b)
      throw std::logic_error("Lemma 2 violated: body of joint " + body.joint_name +
                             " does not precede its parent");
    if (body.parent_lem >= nb) throw std::logic_error("parent index out of range");
  }
  for (int d = 0; d < tree.nv; ++d) {
    const int p = tree.dof_parent[d];
    if (p >= 0 && p <= d) throw std::logic_error("Lemma 2 violated at dof " + std::to_string(d));
    if (tree.M_col_start[d + 1] - tree.M_col_start[d] != tree.dof_depth[d] + 1)
      throw std::logic_error("packed layout inconsistent at dof " + std::to_string(d));
  }
}

std::vector<std::vector<int>> coupled_cuts(const Tree& tree, const std::vector<int>& rows_per_cut) {
  const int ncuts = static_cast<int>(tree.cuts.size());
  std::vector<std::vector<int>> cuts_of_dof(tree.nv);
  for (int c = 0; c < ncuts; ++c)
    if (rows_per_cut[c] > 0)
      for (int d : tree.cuts[c].dofs) cuts_of_dof[d].push_back(c);
  std::vector<std::vector<int>> out(ncuts);
  for (const std::vector<int>& cs : cuts_of_dof)
    for (int a : cs) out[a].insert(out[a].end(), cs.begin(), cs.end());
  for (std::vector<int>& list : out) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return out;
}

std::vector<std::vector<int>> symbolic_cholesky(const std::vector<std::vector<int>>& lower, long long op_limit,
                                                long long* ops) {
  const int m = static_cast<int>(lower.size());
  std::vector<std::vector<int>> pattern(m);
  std::vector<std::vector<int>> children(m);
  long long cost = 0;
  std::vector<int> merged, u;
  for (int j = 0; j < m; ++j) {
    std::vector<int> p = lower[j];
    for (int child : children[j]) {
      merged.clear();
      for (int r : pattern[child])
        if (r > j) merged.push_back(r);
      u.clear();
      std::set_union(p.begin(), p.end(), merged.begin(), merged.end(), std::back_inserter(u));
      p.swap(u);
    }
    const long long c = static_cast<long long>(p.size());
    cost += c * (c + 3) / 2;
    if (op_limit >= 0 && cost > op_limit) {
      if (ops) *ops = cost;
      return {};
    }
    if (!p.empty()) children[p.front()].push_back(j);
    pattern[j] = std::move(p);
  }
  if (ops) *ops = cost;
  return pattern;
}

std::vector<std::vector<int>> constraint_row_pattern(const Tree& tree, const std::vector<int>& rows_per_cut,
                                                     const std::vector<int>& order) {
  const int ncuts = static_cast<int>(tree.cuts.size());
  std::vector<int> first(ncuts + 1, 0);
  for (int c = 0; c < ncuts; ++c) first[c + 1] = first[c] + rows_per_cut[c];
  const int m = first[ncuts];
  std::vector<int> position(m), cut_of_row(m);
  for (int j = 0; j < m; ++j) position[order[j]] = j;
  for (int c = 0; c < ncuts; ++c)
    for (int r = first[c]; r < first[c + 1]; ++r) cut_of_row[r] = c;
  const std::vector<std::vector<int>> coupled = coupled_cuts(tree, rows_per_cut);
  std::vector<std::vector<int>> lower(m);
  for (int j = 0; j < m; ++j) {
    for (int other : coupled[cut_of_row[order[j]]])
      for (int r = first[other]; r < first[other + 1]; ++r)
        if (position[r] > j) lower[j].push_back(position[r]);
    std::sort(lower[j].begin(), lower[j].end());
  }
  return lower;
}

RowOrder constraint_row_order(const Tree& tree, const std::vector<int>& rows_per_cut) {
  const int ncuts = static_cast<int>(tree.cuts.size());
  std::vector<int> first(ncuts + 1, 0);
  for (int c = 0; c < ncuts; ++c) first[c + 1] = first[c] + rows_per_cut[c];
  const int m = first[ncuts];

  // Minimum degree on the elimination graph of cuts: eliminating a cut joins
  // its neighbours into a clique (the fill of Step 3.4), and it leaves the graph.
  std::vector<std::vector<int>> adj = coupled_cuts(tree, rows_per_cut);
  for (int c = 0; c < ncuts; ++c) adj[c].erase(std::remove(adj[c].begin(), adj[c].end(), c), adj[c].end());
  std::vector<long long> degree(ncuts, 0);
  auto update_degree = [&](int c) {
    long long d = 0;
    for (int n : adj[c]) d += rows_per_cut[n];
    degree[c] = d;
  };
  std::vector<char> done(ncuts, 0);
  for (int c = 0; c < ncuts; ++c) {
    update_degree(c);
    if (rows_per_cut[c] == 0) done[c] = 1;
  }
  std::vector<int> md;
  md.reserve(m);
  std::vector<int> u;
  for (;;) {
    int best = -1;
    for (int c = 0; c < ncuts; ++c)
      if (!done[c] && (best < 0 || degree[c] < degree[best])) best = c;
    if (best < 0) break;
    done[best] = 1;
    for (int r = first[best]; r < first[best + 1]; ++r) md.push_back(r);
    const std::vector<int> nbrs = std::move(adj[best]);
    adj[best].clear();
    for (int n : nbrs) {
      u.clear();
      std::set_union(adj[n].begin(), adj[n].end(), nbrs.begin(), nbrs.end(), std::back_inserter(u));
      u.erase(std::remove_if(u.begin(), u.end(), [&](int x) { return x == n || x == best; }), u.end());
      adj[n].swap(u);
      update_degree(n);
    }
  }

  RowOrder out;
  long long md_ops = 0;
  symbolic_cholesky(constraint_row_pattern(tree, rows_per_cut, md), -1, &md_ops);
  std::vector<int> natural(m);
  for (int r = 0; r < m; ++r) natural[r] = r;
  long long natural_ops = 0;
  const bool natural_done =
      !symbolic_cholesky(constraint_row_pattern(tree, rows_per_cut, natural), md_ops, &natural_ops).empty() || m == 0;
  if (natural_done && natural_ops <= md_ops) {
    out.order = natural;
    out.ops = natural_ops;
  } else {
    out.order = md;
    out.minimum_degree = true;
    out.ops = md_ops;
  }
  out.natural_ops = natural_done ? natural_ops : -1;
  return out;
}

}  // namespace jrgen::topology
