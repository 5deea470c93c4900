// Topology analysis: from the user's link/joint tree (ir::Robot) to the body
// tree the solver works on.
//   1. fuse fixed joints: every link is carried by the nearest moving joint
//      above it (or by the fixed base);
//   2. renumber the moving bodies so that descendants come before ancestors
//      (Lemma 2), which makes the block Cholesky factor of M free of fill-in;
//   3. derive the sparsity of M and L at the level of single velocity
//      coordinates ("dofs"): column j of L is non-zero exactly in the rows of
//      j's ancestors (eq. 18 with Lemma 2).
// Pure functions of the IR; no numerics beyond composing frames and inertias.
#pragma once

#include <string>
#include <vector>

#include "ir/ir.hpp"

namespace jrgen::topology {

/// One moving tree joint and the rigid body it carries (its child link plus
/// every link fused to it through fixed joints).  Stored in Lemma 2 order.
struct Body {
  std::string joint_name;
  ir::JointType type = ir::JointType::Revolute;
  int joint_ir = -1;         ///< index into ir::Robot::joints
  int joint_user = -1;       ///< position among moving joints, user order
  int parent_lem = -1;       ///< Lemma 2 index of the parent body; -1: the fixed base
  std::vector<int> children_lem;  ///< in user order
  int nq = 0, nv = 0;
  int q_user = 0, v_user = 0;  ///< first coordinates in user q and v
  int v_lem = 0;               ///< first velocity coordinate in Lemma 2 order
  ir::Pose X_PJ;  ///< joint frame in the parent *body* frame (fixed joints folded in)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();  ///< revolute/prismatic axis, planar normal
  Eigen::Vector3d e1 = Eigen::Vector3d::Zero(), e2 = Eigen::Vector3d::Zero();  ///< planar
  double damping = 0.0;   ///< URDF <dynamics damping> plus a <joint_spring>'s damping
  /// One-dof joints (docs/interface.md section 2b): <joint_spring> stiffness and
  /// rest, <joint_force> value; generalized force -stiffness (q - rest) + force.
  double stiffness = 0.0, rest = 0.0, force = 0.0;
  ir::Inertial inertial;  ///< fused mass properties, body frame
  std::vector<int> links;  ///< ir links carried, child link first
};

/// Where an ir link sits: on body `body_lem` (-1: the fixed base) at X_BL.
struct LinkPlacement {
  int body_lem = -1;
  ir::Pose X_BL;
};

/// A cut joint placed on the body tree.  Its rows follow the order documented
/// in runtime/include/jrgen/runtime.hpp (CutKind).
struct Cut {
  std::string name;
  ir::CutType type = ir::CutType::Spherical;
  int cut_ir = -1;      ///< index into ir::Robot::cuts
  int body_k = -1;      ///< Lemma 2 body carrying the frame on k; -1: the fixed base
  int body_l = -1;
  ir::Pose X_BkF;       ///< frame on k in body k's frame (fixed joints folded in)
  ir::Pose X_BlF;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d child_axis = Eigen::Vector3d::UnitZ();
  double distance = 0.0;
  bool distance_given = false;
  /// Lemma 3: dofs of the bodies on the paths from k and l to the base, in
  /// increasing Lemma 2 order.  Only these rows of T^(j), and these columns of
  /// the cut's rows of Phiq, can be non-zero.
  std::vector<int> dofs;
  /// The first num_distinct dofs lie on one path only; the rest (common
  /// ancestors of k and l) move both frames rigidly, so Phiq is exactly zero
  /// there while T generally is not.
  int num_distinct = 0;
  int rows = 0;                ///< rows of the cut type
  std::vector<int> kept_rows;  ///< rows kept after the redundancy analysis (all by default)
  /// Mimic rows (ir::CutType::Mimic): body_k carries the leader joint, body_l
  /// the mimic joint; Phi = q_l - multiplier q_k - offset.  Every dof of
  /// `dofs` counts as distinct (num_distinct = dofs.size()): the leader may
  /// be an ancestor of the mimic joint.
  double multiplier = 1.0, offset = 0.0;
};

/// A <spring> placed on the body tree (docs/interface.md section 2b).
struct Spring {
  std::string name;
  int spring_ir = -1;          ///< index into ir::Robot::springs
  int body_k = -1, body_l = -1;  ///< Lemma 2 bodies; -1: the fixed base
  Eigen::Vector3d p_k = Eigen::Vector3d::Zero(), p_l = Eigen::Vector3d::Zero();  ///< points, body frames
  double stiffness = 0.0, damping = 0.0, rest_length = 0.0;  ///< rest_length resolved
};

struct Tree {
  std::vector<Body> bodies;  ///< Lemma 2 order
  std::vector<LinkPlacement> links;  ///< one per ir link
  std::vector<int> body_of_user_joint;  ///< moving joint in user order -> Lemma 2 body
  int nq = 0, nv = 0;
  // Dof-level structure, Lemma 2 order (nv entries each).
  std::vector<int> dof_parent;  ///< next dof up the tree, -1 at a root
  std::vector<int> dof_body;    ///< body that owns the dof
  std::vector<int> dof_user;    ///< user velocity index
  std::vector<int> dof_depth;   ///< number of ancestors
  std::vector<int> M_col_start; ///< packed column starts (nv + 1): rows j, parent(j), ...
  std::vector<Cut> cuts;        ///< in ir::Robot::cuts order
  std::vector<Spring> springs;  ///< in ir::Robot::springs order
  std::vector<std::string> notes;  ///< for stderr (bodies raised to MassBounds)

  /// Kept constraint rows (nc).
  int nc() const;
  /// True when a spring, a joint spring's stiffness or a joint force acts
  /// (a joint spring's damping is in Body::damping).
  bool has_force_elements() const;

  int nnz() const { return M_col_start.empty() ? 0 : M_col_start.back(); }
  /// Packed position of (row, col), row an ancestor of or equal to col.
  int packed(int row_lem, int col_lem) const {
    return M_col_start[col_lem] + dof_depth[col_lem] - dof_depth[row_lem];
  }
  /// Ancestors of a dof, nearest first (the non-zero rows of column dof of L below the diagonal).
  std::vector<int> ancestors(int dof_lem) const;
  /// Descendants of every dof, ascending (the family F of Remark 2, dof level).
  std::vector<std::vector<int>> descendants() const;
};

/// A dense supernode of the dof tree: dofs first .. first + size - 1, each the
/// parent of the one before it and (but the first) with no other child, so
/// their columns of L share one dense structure: the lower triangle of these
/// rows plus a panel of the ancestors of the last (rows - size of them).
/// `offset` is the start of its column-major rows x size block in the dense
/// buffer of the supernodal factorization.
struct Supernode {
  int first = 0, size = 0, rows = 0;
  long long offset = 0;
};

/// Maximal supernodes with at least min_size dofs, in increasing `first`;
/// O(nv).
std::vector<Supernode> dense_supernodes(const Tree& tree, int min_size);

/// A complete subtree of the dof tree, dofs first .. root (contiguous in
/// Lemma 2 post-order); `path` = number of ancestors of root (the separator
/// rows it updates); `buffer` = start of its path x path update buffer.
struct Subtree {
  int first = 0, root = 0, path = 0;
  long long buffer = 0;
  long long work = 0;  ///< sum of (depth + 1)^2 over its dofs
};

/// Corollary 3 partition: disjoint subtrees below a separator near the
/// root(s), found by repeatedly moving the root of the costliest subtree
/// (factor work, sum of (depth + 1)^2 over its dofs) into the separator until
/// no subtree holds more than total / parts of the work or the separator
/// would exceed max_separator dofs.  In increasing `first`; O(nv log nv).
std::vector<Subtree> partition_subtrees(const Tree& tree, int parts, int max_separator);

/// Lower bounds on each moving body's fused mass properties
/// (docs/interface.md section 1, --bound-mass and --bound-inertia; MuJoCo's
/// boundmass and boundinertia).  0: no bound.
struct MassBounds {
  double mass = 0.0;     ///< kg
  double inertia = 0.0;  ///< kg m^2, each principal moment about the centre of mass
};

/// Steps 1-3 above.  Raises bodies below `bounds` to them (one note each in
/// Tree::notes).  Throws jrgen::Error for trees whose mass matrix would be
/// singular for structural reasons (a moving body that carries no mass) and
/// for any non-finite constant (a frame or a fused inertia that overflows).
Tree build_tree(const ir::Robot& robot, const MassBounds& bounds = {});

/// Places robot.springs, joint_springs and joint_forces on the bodies of
/// `tree` (called by build_tree; generator/topology/forces.cpp).  A spring
/// without rest_length takes its points' distance at the zero configuration;
/// throws jrgen::Error when that distance is zero (the direction of the force
/// at rest would be undefined), when both points sit on one body after fixed
/// joints are fused, or when a placed point overflows.
void place_force_elements(const ir::Robot& robot, Tree& tree);

/// Whether velocity coordinate k of a joint of this type is a translation, in
/// the joint's own dof order (docs/coordinates.md: floating p_dot then omega,
/// planar x, y then theta).
bool dof_translates(ir::JointType type, int k);

/// For every dof (Lemma 2 order), an upper bound of M's diagonal entry M_jj
/// over all configurations: the subtree's mass for a translation, and for a
/// rotation the sum over the subtree of m_b r_b^2 + trace(I_b), r_b bounded by
/// the joint offsets on the path (infinity when a joint below the dof
/// translates: no such bound).  The articulated-body routes, which form no
/// M, test their pivots against it (docs/status.md).
std::vector<double> mass_diagonal_bounds(const Tree& tree);

/// The precondition the generated factorization relies on (docs/conventions.md, "Errors",
/// as Pinocchio's CRBA checker): parent after child, dof chains consistent,
/// packed layout complete.  Throws std::logic_error when violated.
void check_lemma2(const Tree& tree);

// ---- Elimination order of the constraint rows (Step 3.4) ------------------------
//
// Remark 4 treats T^T T as dense.  Its entry (r, s) is structurally non-zero
// only when the cuts of rows r and s share a dof of their Lemma 3 lists, so
// for mechanisms made of weakly coupled loops (vehicle trains: block
// tridiagonal) the order in which its rows are eliminated decides the fill
// of its Cholesky factor.

/// Cuts whose Lemma 3 dof lists intersect, per cut (ascending, the cut
/// itself included), among cuts with rows_per_cut[c] > 0 (others: empty).
std::vector<std::vector<int>> coupled_cuts(const Tree& tree, const std::vector<int>& rows_per_cut);

/// Symbolic Cholesky factorization of a symmetric pattern given in
/// elimination positions: lower[j] = structurally non-zero rows > j of column
/// j (ascending).  Returns the factor's rows > j per column, fill included
/// (column j gets the rows of every column whose first off-diagonal row, its
/// elimination-tree parent, is j).  When op_limit >= 0 and the factor's cost
/// sum_j |column j| (|column j| + 3) / 2 exceeds it, gives up and returns an
/// empty vector.  *ops receives that cost.
std::vector<std::vector<int>> symbolic_cholesky(const std::vector<std::vector<int>>& lower, long long op_limit,
                                                long long* ops);

/// Pattern of T^T T (or of Phiq Phiq^T) in elimination positions: for an
/// elimination order `order` (position -> row; rows numbered cut by cut,
/// rows_per_cut[c] rows for cut c), the structurally non-zero rows > j of
/// column j.
std::vector<std::vector<int>> constraint_row_pattern(const Tree& tree, const std::vector<int>& rows_per_cut,
                                                     const std::vector<int>& order);

struct RowOrder {
  std::vector<int> order;  ///< elimination position -> row (rows numbered cut by cut)
  bool minimum_degree = false;  ///< false: the natural (cut, row) order
  long long ops = 0;            ///< cost of the factor in that order (symbolic_cholesky)
  long long natural_ops = -1;   ///< cost in the natural order (-1: not finished, above ops)
};

/// A fill-reducing elimination order of the constraint rows: minimum degree
/// on the graph of cuts (rows of one cut are indistinguishable: a clique
/// sharing every neighbour, so they are eliminated together, in their own
/// order).  The degree of a cut is the number of rows of the cuts adjacent
/// to it in the elimination graph; ties go to the lowest cut index, so the
/// order is deterministic.  The natural (cut, row) order is kept when its
/// factor costs no more (symbolic_cholesky), so a model never gets worse.
RowOrder constraint_row_order(const Tree& tree, const std::vector<int>& rows_per_cut);

/// Composition helpers on ir::Pose.
ir::Pose compose(const ir::Pose& X_AB, const ir::Pose& X_BC);

}  // namespace jrgen::topology
