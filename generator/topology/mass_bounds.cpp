// Upper bounds of M's diagonal over all configurations (issue 29, item 3):
// the reference of the articulated-body routes' relative pivot test, which
// forms no M (docs/status.md, "How the digits are checked").
#include <cmath>
#include <limits>

#include "topology/topology.hpp"

namespace jrgen::topology {
namespace {

constexpr double kUnbounded = std::numeric_limits<double>::infinity();

bool translates(ir::JointType type) {
  return type == ir::JointType::Prismatic || type == ir::JointType::Planar || type == ir::JointType::Floating;
}

}  // namespace

bool dof_translates(ir::JointType type, int k) {
  switch (type) {
    case ir::JointType::Prismatic: return true;
    case ir::JointType::Floating: return k < 3;
    case ir::JointType::Planar: return k < 2;
    default: return false;
  }
}

// Lemma 2 order puts children first, so one pass accumulates each subtree:
// its mass m, the sum of trace(I_com) t, its reach R (the largest distance
// from the body's joint origin to a centre of mass below it, by the triangle
// inequality over the joint offsets X_PJ; infinite when a joint below
// translates) and S >= sum m_b r_b^2 about that origin.  For a unit axis a
// through the origin, M_jj = sum m_b |a x r_b|^2 + a^T I_b a <= S + t.
std::vector<double> mass_diagonal_bounds(const Tree& tree) {
  const int nb = static_cast<int>(tree.bodies.size());
  std::vector<double> mass(nb, 0.0), trace(nb, 0.0), reach(nb, 0.0), second(nb, 0.0);
  std::vector<bool> moving_below(nb, false);
  for (int b = 0; b < nb; ++b) {
    const Body& body = tree.bodies[b];
    const double c = body.inertial.com.norm();
    mass[b] += body.inertial.mass;
    trace[b] += body.inertial.I_com.trace();
    second[b] += body.inertial.mass * c * c;
    reach[b] = std::max(reach[b], c);
    if (body.parent_lem < 0) continue;
    const int p = body.parent_lem;
    const double offset = body.X_PJ.p.norm();
    const double r = translates(body.type) || moving_below[b] ? kUnbounded : offset + reach[b];
    moving_below[p] = moving_below[p] || translates(body.type) || moving_below[b];
    mass[p] += mass[b];
    trace[p] += trace[b];
    reach[p] = std::max(reach[p], r);
    second[p] += std::isinf(r) ? kUnbounded : mass[b] * r * r;
  }
  std::vector<double> bound(tree.nv, kUnbounded);
  for (int b = 0; b < nb; ++b) {
    const Body& body = tree.bodies[b];
    for (int k = 0; k < body.nv; ++k)
      bound[body.v_lem + k] = dof_translates(body.type, k) ? mass[b] : second[b] + trace[b];
  }
  return bound;
}

}  // namespace jrgen::topology
