// jrgen runtime: kinematics and dynamics terms of a tree mechanism, evaluated
// for any model the generator describes.  The generated solvers call it for
// M (packed), h, and (closed loops) Phi, Phiq, gamma, then run their own
// straight-line factorization.  The runtime knows nothing of the generator:
// a model is a set of constant tables (model/data split, as in MuJoCo's
// mjModel/mjData):
//   Model      immutable description, usually constexpr tables in generated code;
//   BodyState  per-body workspace, one array of Model::nb entries, owned by the caller.
//
// Index spaces (docs/conventions.md): bodies and the rows/columns of the packed
// M are in Lemma 2 order (descendants before ancestors, so parent > child);
// q, v, tau and dense matrices handed to users are in user order.
//
// Spatial vectors are 6-D, angular part first, in body coordinates.
#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace jr {

/// Joint kinds of the spanning tree; every joint is "translate in the joint
/// frame, then rotate" (docs/conventions.md).
enum class JointKind : std::int32_t {
  kRevolute = 0,   ///< nq = nv = 1, rotation about `axis`
  kPrismatic = 1,  ///< nq = nv = 1, translation along `axis`
  kBall = 2,       ///< nq = 4 (w,x,y,z), nv = 3 (omega in child frame)
  kFloating = 3,   ///< nq = 7 (p, quat), nv = 6 (pdot in joint frame, omega in child)
  kPlanar = 4,     ///< nq = nv = 3: translation along e1, e2, rotation about axis
};

/// One moving tree joint and the (fused) body it carries.  Lemma 2 order.
struct BodyModel {
  const char* joint_name;  ///< the URDF joint, for diagnostics
  JointKind kind;
  std::int32_t parent;  ///< Lemma 2 index of the parent body, -1: the fixed base; parent > self
  std::int32_t q_user;  ///< first position coordinate in user q
  std::int32_t v_user;  ///< first velocity coordinate in user v
  std::int32_t v_lem;   ///< first velocity coordinate in Lemma 2 order
  std::int32_t nv;      ///< velocity coordinates of the joint
  double R_PJ[9];       ///< joint frame in the parent body frame: rotation, row-major
  double p_PJ[3];       ///< joint frame origin in the parent body frame
  double axis[3];       ///< unit axis in the joint frame (revolute, prismatic; planar normal)
  double e1[3], e2[3];  ///< planar in-plane directions in the joint frame
  double mass;          ///< fused body mass
  double com[3];        ///< centre of mass in the body frame
  double I_com[6];      ///< inertia about the com, body axes: xx yy zz xy xz yz
  double damping;       ///< viscous damping on each velocity coordinate
};

/// A whole tree.  Packed M: column j (Lemma 2 dof order) holds the rows j,
/// dof_parent[j], dof_parent[dof_parent[j]], ... (its ancestors, Lemma 2 /
/// eq. (18): no other entry is structurally non-zero), starting at
/// M_col_start[j]; M_col_start[nv] is the number of stored entries.
struct Model {
  std::int32_t nb;  ///< moving bodies (= tree joints with nv > 0)
  std::int32_t nq;
  std::int32_t nv;
  const BodyModel* bodies;          ///< (nb) Lemma 2 order
  const std::int32_t* dof_parent;   ///< (nv) Lemma 2 dof tree, -1 at a root
  const std::int32_t* dof_user;     ///< (nv) Lemma 2 dof -> user velocity index
  const std::int32_t* M_col_start;  ///< (nv + 1) packed column starts
  double gravity[3];                ///< in the world (= fixed base) frame
};

/// Rigid-body inertia about a frame origin: mass, first moment h = m c and
/// rotational inertia about the origin, all in that frame's coordinates.
struct SpatialInertia {
  double m = 0.0;
  Eigen::Vector3d h = Eigen::Vector3d::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
};

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6Xd = Eigen::Matrix<double, 6, 6>;  // only the first nv columns are used

/// Per-body workspace (Lemma 2 order), filled by kinematics() and the passes
/// below.  The caller owns an array of Model::nb of them; nothing allocates.
struct BodyState {
  Eigen::Matrix3d R;   ///< R_PC: body frame C to parent body frame P
  Eigen::Vector3d p;   ///< p_PC: body origin in P
  Eigen::Matrix3d R_J; ///< rotation of the joint alone (C relative to J)
  Matrix6Xd S;         ///< motion subspace in C coordinates, first nv columns
  Vector6d v;          ///< body velocity, C coordinates
  Vector6d a;          ///< body bias acceleration (qdd = 0), C coordinates
  Vector6d f;          ///< body force, C coordinates
  SpatialInertia Ic;   ///< composite inertia of the subtree, C coordinates
  Eigen::Matrix3d R_WC;  ///< world orientation (world_poses())
  Eigen::Vector3d p_WC;  ///< world position (world_poses())
};

/// Joint transforms X_PC and motion subspaces S for configuration q (nq,
/// user order).  Quaternions are normalized before use.
void kinematics(const Model& model, BodyState* bodies, const double* q);

/// World placement of every body (needs kinematics()).
void world_poses(const Model& model, BodyState* bodies);

/// Composite inertia matrix, eq. (14) and (18), by the composite-rigid-body
/// recursion, written into the packed layout of Model::M_col_start
/// (Mp: M_col_start[nv] entries).  Needs kinematics().
void mass_matrix_packed(const Model& model, BodyState* bodies, double* Mp);

/// Bias forces h (nv, Lemma 2 order) with v in user order: Coriolis and
/// centrifugal terms, plus gravity when kGravity, plus damping * v when
/// kDamping (recursive Newton-Euler with qdd = 0).  Needs kinematics().
/// Instantiated for the four combinations.
template <bool kGravity, bool kDamping>
void bias_forces(const Model& model, BodyState* bodies, const double* v, double* h_lem);

/// Runtime switch over the four instantiations.
void bias_forces(const Model& model, BodyState* bodies, const double* v, double* h_lem,
                 bool gravity, bool damping);

/// Dense nv x nv column-major M in user order from the packed one.
void unpack_mass_matrix(const Model& model, const double* Mp, double* M_user);

/// Packed M from a dense column-major user-order M: reads only the
/// structurally non-zero entries.
void pack_mass_matrix(const Model& model, const double* M_user, double* Mp);

/// Position of entry (row, col) of the packed M, both Lemma 2 dofs with row an
/// ancestor of (or equal to) col; -1 when structurally zero.
std::int32_t packed_index(const Model& model, std::int32_t row_lem, std::int32_t col_lem);

/// Result codes of the generated solvers (INTERFACE.md section 4).
enum Status : int {
  kSuccess = 0,
  kMassNotPositiveDefinite = 1,  ///< a pivot of M's factorization was <= 0 (or NaN)
  kConstraintsSingular = 2,      ///< T^T T is singular: the constraint rows are dependent
  kNonFinite = 3,                ///< a NaN or infinity reached the result
};

/// Human-readable name of a status code.
const char* status_name(int status);

}  // namespace jr
