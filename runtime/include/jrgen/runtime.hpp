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
#include <algorithm>
#include <cstdint>
#include <cstring>
#if defined(__SSE2__) && !defined(JRGEN_PORTABLE_SIMD)
#include <emmintrin.h>
#endif

#include "jrgen/simd.hpp"

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
/// Every pass of forward dynamics sweeps this array, so the fields they use
/// come first and S last among them: only its first nv columns are ever
/// written or read, and the rest of it (5 of 6 columns for a revolute joint)
/// never reaches the caches.  Large models outgrow L2 on this array
/// (docs/benchmarks.md, run 3), so its touched size is the per-body cost.
struct BodyState {
  Eigen::Matrix3d R;   ///< R_PC: body frame C to parent body frame P
  Eigen::Vector3d p;   ///< p_PC: body origin in P
  Vector6d v;          ///< body velocity, C coordinates
  Vector6d a;          ///< body bias acceleration (qdd = 0), C coordinates
  Vector6d f;          ///< body force, C coordinates
  SpatialInertia Ic;   ///< composite inertia of the subtree, C coordinates
  Matrix6Xd S;         ///< motion subspace in C coordinates; only the first nv columns are set
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

// ---- Force elements (docs/interface.md section 2b) -----------------------------------
//
// Springs, joint springs and joint forces are part of h (Q = tau - h):
//   spring (points a on body k, b on body l, d = b - a, L = |d|): the force
//     F = stiffness (L - rest_length) + damping dL/dt pulls the points
//     together, f_b = -F d / L on b and f_a = -f_b on a; h -= J_b^T f_b + J_a^T f_a;
//   joint spring and joint force on a one-dof joint: h += stiffness (q - rest) - force
//     (the joint spring's damping is in BodyModel::damping).
// L is computed as sqrt(d.d + kSpringLengthGuard): where the points coincide
// (no direction) the force is zero, and for L > 1e-142 m the guard changes no
// bit of L (1e-300 is below half an ulp of d.d there).  The potential is
//   V = -sum_b m_b g . c_b + sum_springs 1/2 k (L - L0)^2 + sum_joints 1/2 k (q - rest)^2
// (c_b the world centre of mass), so h(q, 0) = dV/dq - force.

inline constexpr double kSpringLengthGuard = 1e-300;

struct SpringModel {
  const char* name;       ///< the <spring>, for diagnostics
  std::int32_t body_k;    ///< Lemma 2 body of point a, -1: the fixed base
  std::int32_t body_l;    ///< Lemma 2 body of point b, -1: the fixed base
  double p_k[3];          ///< a in body k's frame
  double p_l[3];          ///< b in body l's frame
  double stiffness, damping, rest_length;
};

/// A one-dof joint's <joint_spring> stiffness and rest, and <joint_force>.
struct JointForceModel {
  std::int32_t body;  ///< Lemma 2 body of the joint (nv = 1)
  double stiffness, rest, force;
};

struct ForceModel {
  std::int32_t nsprings;
  const SpringModel* springs;
  std::int32_t njoints;
  const JointForceModel* joints;
};

/// Adds the force elements' part of h (Lemma 2 order) at (q, v) to h_lem.
/// Needs kinematics(); overwrites the world poses (world_poses()).
void force_elements(const Model& model, const ForceModel& forces, BodyState* bodies, const double* q,
                    const double* v, double* h_lem);

/// V(q) above (forces may be nullptr: gravity alone).  Runs kinematics().
double potential_energy(const Model& model, const ForceModel* forces, BodyState* bodies, const double* q);

// ---- Cut joints (closed loops) ------------------------------------------------
//
// A cut joint constrains a joint frame Fk fixed on body k to a joint frame Fl
// fixed on body l (either may be the fixed base, index -1).  Its rows, before
// redundant ones are dropped (docs/interface.md section 2), are built from three
// kinds of scalar constraint, all expressed in the frame on k where a
// direction is needed (so a redundant row stays redundant when the whole
// mechanism moves):
//   point    e . (p_l - p_k)            e a unit direction fixed in Fk
//   dot      a . b                      a fixed in Fk, b fixed in Fl
//   distance (|p_l - p_k|^2 - D^2) / (2 D)
// with p_k, p_l the frame origins.  Rows per type:
//   spherical   point x, y, z
//   revolute    point x, y, z; dot(u, axis_l), dot(w, axis_l)
//   prismatic   dot(y_k, z_l), dot(z_k, x_l), dot(x_k, y_l); point u, point w
//   cylindrical dot(u, axis_l), dot(w, axis_l); point u, point w
//   universal   point x, y, z; dot(axis, child_axis)
//   fixed       point x, y, z; dot(y_k, z_l), dot(z_k, x_l), dot(x_k, y_l)
//   distance    distance
//   mimic       q_l - m q_k - o   (URDF <mimic>, docs/interface.md section 2b)
// where u, w complete the axis to a right-handed orthonormal basis in Fk and
// axis_l is the same axis vector expressed in Fl.  A mimic row is not a
// frame constraint: body l carries the mimic joint and body k its leader
// (both one-dof joints), m is stored in axis[0] and o in distance; its
// Jacobian holds 1 and -m in their columns and gamma = 0 (Phi is linear in
// q).  The leader may be an ancestor of the mimic joint, so its entries are
// written for every dof of the cut's list (zeros elsewhere).

enum class CutKind : std::int32_t {
  kSpherical = 0,
  kRevolute = 1,
  kPrismatic = 2,
  kCylindrical = 3,
  kUniversal = 4,
  kFixed = 5,
  kDistance = 6,
  kMimic = 7,
};

/// Number of rows of a cut kind before any is dropped.
int cut_kind_rows(CutKind kind);

struct CutModel {
  const char* name;      ///< the <loop_joint>, for diagnostics
  CutKind kind;
  std::int32_t body_k;   ///< Lemma 2 body carrying Fk, -1: the fixed base
  std::int32_t body_l;   ///< Lemma 2 body carrying Fl, -1: the fixed base
  double R_k[9];         ///< Fk in body k's frame: rotation, row-major
  double p_k[3];
  double R_l[9];         ///< Fl in body l's frame
  double p_l[3];
  double axis[3];        ///< unit, in Fk (revolute, prismatic, cylindrical, universal)
  double child_axis[3];  ///< unit, in Fl (universal)
  double distance;       ///< D (distance cuts)
  std::int32_t row_mask;   ///< bit r set: row r is kept
  std::int32_t first_row;  ///< index of the first kept row in Phi
  std::int32_t phiq_start; ///< first entry of this cut's rows in the packed Phiq
  std::int32_t num_dofs;   ///< structural non-zeros per row (dofs on the paths of k and l to the base)
};

/// Packed constraint Jacobian: kept row r of cut c stores num_dofs entries,
/// the dofs on the paths from k and from l to the base in increasing Lemma 2
/// order (Lemma 3: exactly the rows of T^(c) that can be non-zero), starting
/// at phiq_start + r_kept * num_dofs.  Dofs on both paths (the common
/// ancestors, a suffix of the list) move both frames rigidly: their Jacobian
/// entries are exactly zero and are neither computed nor written.
struct ConstraintModel {
  std::int32_t ncuts;
  std::int32_t nc;          ///< kept rows
  std::int32_t phiq_nnz;    ///< stored Jacobian entries
  const CutModel* cuts;
};

/// Per-body motion in world coordinates, for the constraint pass.
struct BodyMotion {
  Eigen::Matrix3d R;      ///< R_WB
  Eigen::Vector3d p;      ///< p_WB
  Eigen::Vector3d w;      ///< angular velocity, world
  Eigen::Vector3d v;      ///< velocity of the body origin, world
  Eigen::Vector3d alpha;  ///< angular acceleration at qdd = 0, world
  Eigen::Vector3d a;      ///< acceleration of the body origin at qdd = 0, world
};

/// Phi (nc) of the kept rows at q.  Needs nothing precomputed.
void constraints(const Model& model, const ConstraintModel& cm, BodyState* bodies, const double* q,
                 double* phi);

/// Phi (may be nullptr), the packed Jacobian Phiq_p (phiq_nnz, with respect to
/// the velocity coordinates; common-ancestor entries untouched) and
/// gamma = -(d/dt Phiq) v (may be nullptr; then v may be nullptr) at (q, v).
/// Needs kinematics().  `motion` is a workspace of Model::nb entries.
void constraint_terms(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                      BodyMotion* motion, const double* q, const double* v, double* phi,
                      double* Phiq_p, double* gamma);

/// Every row of every cut (row masks ignored), dense: Phi_all (sum of rows)
/// and Phiq_all (rows x nv, column-major, user order).  For generation-time
/// analysis; allocates nothing but is O(rows * nv).
void constraints_all_rows(const Model& model, const ConstraintModel& cm, BodyState* bodies,
                          BodyMotion* motion, const double* q, double* phi_all, double* Phiq_all);

/// Dense nc x nv column-major user-order Phiq from the packed one.
void unpack_constraint_jacobian(const Model& model, const ConstraintModel& cm, const double* Phiq_p,
                                double* Phiq_user);

// ---- Table-driven factorization (large models) -------------------------------
//
// The factorization and substitutions of the generated straight-line Steps
// 1, 2 and 4 (the same operations, in another order), as loops over the
// packed layout: for models whose unrolled code would be too
// large to compile (the generator chooses).  Right-looking: column j (Lemma 2
// order, leaves first) is final once its descendants are done; its pivot is
// checked, the outer product of its ancestor rows (over the pivot) is
// subtracted from the columns of the ancestors (which are all in the chain,
// so no fill-in, Lemma 2), and the rows are scaled.  L L^T and L D L^T share
// that order: only the final scale differs (1 / sqrt(pivot) or 1 / pivot),
// so the square root is not on the chain from one column to the next.

/// In-place L L^T (ldlt false) or L D L^T (ldlt true, D on the diagonal) of
/// the packed M; Dinv[j] = 1 / pivot.  Returns -1, or the Lemma 2 dof whose
/// pivot was <= pivot_tolerance * M[j, j] (or NaN); its pivot in *pivot.
std::int32_t factor_packed(const Model& model, double* L, double* Dinv, bool ldlt, double pivot_tolerance,
                           double* pivot);

/// Row access to the packed factor, for the table-driven Steps 2 and 4.
/// Walking a column's ancestors through dof_parent is a chain of dependent
/// loads, and Step 2 by columns subtracts into the same few ancestor entries
/// over and over; with these tables Step 4 gathers each column's ancestor
/// entries by index, and Step 2 sums each row over its descendants (Remark 2)
/// into a register.  The generator emits them for table-driven solvers;
/// fill_packed_rows() computes the same tables at run time.
struct PackedRows {
  const std::int32_t* entry_row;  ///< (M_col_start[nv]) the row (dof) of each stored entry
  const std::int32_t* row_start;  ///< (nv + 1) row j's off-diagonal entries are [row_start[j], row_start[j + 1])
  const std::int32_t* row_entry;  ///< (M_col_start[nv] - nv) their positions in the packed L, by column ascending
  const std::int32_t* row_col;    ///< (M_col_start[nv] - nv) their columns (descendants of the row's dof)
};

/// Fills the arrays of PackedRows (sizes as documented there) for model.
void fill_packed_rows(const Model& model, std::int32_t* entry_row, std::int32_t* row_start, std::int32_t* row_entry,
                      std::int32_t* row_col);

/// Step 2, L z = Q in place (unit diagonal with ldlt: D^-1 waits for Step 4).
void forward_packed(const Model& model, const PackedRows& rows, const double* L, const double* Dinv, bool ldlt,
                    double* z);

/// Step 4, L^T x = z (ldlt: D^-1 applied first) in place.
void backward_packed(const Model& model, const PackedRows& rows, const double* L, const double* Dinv, bool ldlt,
                     double* z);

/// True when some x[i], i < n, is a NaN or an infinity (every exponent bit
/// set).  Integer tests only (no floating-point operation, so no flag is
/// raised and no trap taken), independent per entry: no chain of dependent
/// floating-point operations on the solver's hot path.  With SSE2 two entries
/// per instruction: the high 32 bits of each double hold its exponent.
inline bool any_non_finite(const double* x, std::int32_t n) {
  constexpr std::uint64_t kExponent = 0x7ff0000000000000ULL;
  std::int32_t i = 0;
  std::uint64_t bad = 0;
#if defined(__SSE2__) && !defined(JRGEN_PORTABLE_SIMD)
  const __m128i high = _mm_set1_epi32(0x7ff00000);
  __m128i acc = _mm_setzero_si128();
  for (; i + 2 <= n; i += 2) {
    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(x + i));
    acc = _mm_or_si128(acc, _mm_cmpeq_epi32(_mm_and_si128(v, high), high));
  }
  // Lanes 1 and 3: the high halves (the low halves hold mantissa bits).
  bad = static_cast<std::uint64_t>(_mm_movemask_ps(_mm_castsi128_ps(acc)) & 0xA);
#endif
  for (; i < n; ++i) {
    std::uint64_t bits;
    std::memcpy(&bits, x + i, sizeof bits);
    bad |= static_cast<std::uint64_t>((bits & kExponent) == kExponent);
  }
  return bad != 0;
}

/// The digits test on a finished factor (issue 19: status 0 means the
/// digits are there).  The per-pivot test of the factorizations compares
/// pivot j with its own diagonal entry, which cannot see a matrix whose
/// smallness is in a whole row and column: a constraint row that vanishes at
/// a singular configuration (T^T T's diagonal entry then vanishes with its
/// pivot), or a dof of a link without inertia about its axis (icub's neck).
/// This test compares the smallest pivot d_min of A = L D L^T with the
/// largest, d_max.  Every pivot lies in [lambda_min(A), lambda_max(A)]
/// (d_j = 1 / (A_jj^-1 of the leading j x j block): Cauchy interlacing), so
///     d_max / d_min <= cond2(A):
/// a spread beyond 1 / limit proves cond2(A) > 1 / limit.
///
/// x: the n > 0 pivots (inverse false) or their reciprocals (inverse true),
/// all positive (the factor passed its per-pivot test); power 1 for the d_j
/// of L D L^T, 2 for the l_j = sqrt(d_j) of L L^T.  Returns -1 when
/// d_min >= limit * d_max, else the index of the smallest pivot, with
/// d_min / d_max in *ratio.  Two min/max chains of n / 2 SSE2 steps, no
/// division on the success path.
inline std::int32_t pivot_spread(const double* x, std::int32_t n, bool inverse, int power, double limit,
                                 double* ratio) {
  double lo = x[0], hi = x[0];
  std::int32_t i = 0;
#if defined(__SSE2__) && !defined(JRGEN_PORTABLE_SIMD)
  if (n >= 2) {
    __m128d vlo = _mm_loadu_pd(x), vhi = vlo;
    for (i = 2; i + 2 <= n; i += 2) {
      const __m128d v = _mm_loadu_pd(x + i);
      vlo = _mm_min_pd(vlo, v);
      vhi = _mm_max_pd(vhi, v);
    }
    lo = std::min(_mm_cvtsd_f64(vlo), _mm_cvtsd_f64(_mm_unpackhi_pd(vlo, vlo)));
    hi = std::max(_mm_cvtsd_f64(vhi), _mm_cvtsd_f64(_mm_unpackhi_pd(vhi, vhi)));
  }
#endif
  for (; i < n; ++i) {
    lo = std::min(lo, x[i]);
    hi = std::max(hi, x[i]);
  }
  // d_min / d_max = (lo / hi)^power, with or without reciprocals.
  const bool spread = power == 2 ? lo * lo < limit * (hi * hi) : lo < limit * hi;
  if (!spread) return -1;
  const double r = lo / hi;
  *ratio = power == 2 ? r * r : r;
  const double smallest = inverse ? hi : lo;
  for (i = 0; i < n; ++i)
    if (x[i] == smallest) break;
  return i;
}

/// Result codes of the generated solvers (docs/interface.md section 4).
enum Status : int {
  kSuccess = 0,
  kMassNotPositiveDefinite = 1,  ///< a pivot of M's factorization was <= 0 (or NaN)
  kConstraintsSingular = 2,      ///< T^T T is singular: the constraint rows are dependent
  kNonFinite = 3,                ///< a NaN or infinity reached the result
};

/// Human-readable name of a status code.
const char* status_name(int status);

}  // namespace jr
