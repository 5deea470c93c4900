// Seeded random URDF generators for tests and benchmarks.
//
// Every generator is a pure function of its arguments: the same options give
// byte-identical text on every platform (own uniform-deviate code on top of
// std::mt19937_64, whose output sequence the standard fixes; numbers printed
// in the classic locale).
#pragma once

#include <cstdint>
#include <string>

namespace jrgen::testing {

struct RandomTreeOptions {
  std::uint64_t seed = 1;
  /// Bodies (links other than the root "world").  With floating_base the
  /// first body is the floating base and counts as one of them.  >= 1.
  int num_bodies = 10;
  /// Largest depth of a body below "world" (the world has depth 0); 0: unbounded.
  /// With floating_base the world carries only the floating joint, so a bound
  /// of 1 allows a single body.
  int max_depth = 0;
  /// Body 1 hangs on a floating joint from "world"; no other body attaches to
  /// the world.
  bool floating_base = false;
  /// 0: one random tree.  B > 0: a scene of many small mechanisms.  The
  /// bodies come in consecutive groups of B (the last group may be smaller);
  /// each group is one mechanism, whose first body attaches to "world" and
  /// every other body to a uniformly drawn earlier body of the same group
  /// whose depth is < max_depth.  Every mechanism is then drawn from the same
  /// distribution, whatever num_bodies is, so the work per dof (the depth of
  /// the dofs, the entries of L) does not grow with the size of the scene.
  /// Not with floating_base.
  int mechanism_bodies = 0;
  /// Joint type weights (normalized by their sum) for every joint except the
  /// floating base's.
  double p_revolute = 0.45, p_continuous = 0.1, p_prismatic = 0.15, p_ball = 0.2,
         p_planar = 0.05, p_fixed = 0.05;
  /// Masses are drawn log-uniformly in [1 kg, mass_ratio kg]; >= 1.
  double mass_ratio = 1.0;
  /// Write a <dynamics damping> (log-uniform in [0.01, 1]) on every joint with
  /// motion except the floating base.
  bool damping = true;
};

/// A random tree.  Robot name "random_<seed>_<num_bodies>", root link "world",
/// bodies "body_1" ... "body_N" in creation order, joint "joint_i" has child
/// "body_i".  Body i attaches to a uniformly drawn earlier body (or the world)
/// whose depth is < max_depth.  Joint origins: xyz uniform in [-0.5, 0.5]^3,
/// rpy uniform in [-pi, pi]^3; axes uniform on the unit sphere, planar normals
/// +x, +y or +z.  Inertias: principal moments m (d2 + d3), m (d1 + d3),
/// m (d1 + d2) with d_i uniform in [0.002, 0.05] m^2 (so the triangle
/// inequality holds strictly), rotated by a uniformly random rotation; centre
/// of mass uniform in [-0.2, 0.2]^3.  Fixed joints are included as drawn
/// (jrgen fuses their bodies).  Throws std::invalid_argument on bad options.
std::string random_tree_urdf(const RandomTreeOptions& options);

/// A serial chain of num_joints revolute joints from "world" (robot name
/// "chain_<seed>_<num_joints>", links "link_1" ..., joints "joint_1" ...),
/// with random origins, axes, inertias (as above, masses in [1, 2] kg) and
/// damping.  num_joints >= 1.
std::string chain_urdf(int num_joints, std::uint64_t seed);

/// Returns the URDF with a link "jr_world" and a floating joint
/// "jr_floating_base" (origin identity) from it to the current root link (the
/// link that is no joint's child); the new elements come first in <robot>, the
/// rest of the document is kept (re-serialized by TinyXML).  Throws
/// std::invalid_argument when the text is not a URDF with exactly one root
/// link, or already uses the names jr_world / jr_floating_base.
std::string add_floating_base(const std::string& urdf_text);

}  // namespace jrgen::testing

namespace jrgen::testing {

/// A URDF and the text of its --cuts file.
struct ModelWithCuts {
  std::string urdf;
  std::string cuts;
};

/// A vehicle train (issue 4, item 3): `vehicles` copies of a vehicle model
/// (`vehicle_urdf`, whose root link "world" carries one floating joint, and
/// its <loop_joints> `vehicle_cuts`), each on its own floating joint to the
/// world.  Copy i (0-based) has every link, joint and loop joint name
/// prefixed with "v<i>_" and its floating joint's origin moved by
/// -i * spacing along x; consecutive vehicles are coupled by spherical cut
/// joints "hitch_<i>" (vehicle i's root link at (-spacing/2, 0, 0) to
/// vehicle i+1's root link at (+spacing/2, 0, 0), both in the link frames),
/// which coincide at the zero configuration, so the train assembles there.
/// Cuts file order: every vehicle's own cuts, vehicle by vehicle, then the
/// hitches.  Robot name "train_<vehicles>".  Throws std::invalid_argument
/// when vehicles < 1 or the vehicle is not of that shape.
ModelWithCuts vehicle_train(int vehicles, const std::string& vehicle_urdf, const std::string& vehicle_cuts,
                            double spacing = 6.0);

}  // namespace jrgen::testing
