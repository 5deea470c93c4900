// A second, independent implementation of Andrews' squeezing mechanism: the formulas of
// the Test Set for IVP Solvers' andrews.f (subroutine andfunc: M(q), f(q, v), g(q) and its
// Jacobian G(q) = dg/dq), which are Hairer & Wanner's eq. (VII.7.11), in the test set's own
// seven angles y = (beta, Theta, gamma, Phi, delta, Omega, epsilon).  Nothing here comes
// from jrgen: the equations of motion are M w = f - G^T lambda, G w = -c(q, v), where c is
// d^2 g / dt^2 at w = 0 (derived below from g by hand).
#pragma once

#include <cmath>

#include "andrews_reference.hpp"

namespace andrews_ts {

using namespace andrews_ref;

struct Trig {
  double sb, sth, sg, sph, sd, som, sep, cb, cth, cg, cph, cd, com, cep;
  double sbth, sphd, somep, cbth, cphd, comep;
  explicit Trig(const double* y)
      : sb(std::sin(y[0])), sth(std::sin(y[1])), sg(std::sin(y[2])), sph(std::sin(y[3])),
        sd(std::sin(y[4])), som(std::sin(y[5])), sep(std::sin(y[6])), cb(std::cos(y[0])),
        cth(std::cos(y[1])), cg(std::cos(y[2])), cph(std::cos(y[3])), cd(std::cos(y[4])),
        com(std::cos(y[5])), cep(std::cos(y[6])), sbth(std::sin(y[0] + y[1])),
        sphd(std::sin(y[3] + y[4])), somep(std::sin(y[5] + y[6])),
        cbth(std::cos(y[0] + y[1])), cphd(std::cos(y[3] + y[4])),
        comep(std::cos(y[5] + y[6])) {}
};

// M(y), 7 x 7, row-major (andfunc's m(i, j)).
inline void mass(const double* y, double M[7][7]) {
  const Trig t(y);
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j) M[i][j] = 0;
  M[0][0] = m1 * ra * ra + m2 * (rr * rr - 2 * da * rr * t.cth + da * da) + i1 + i2;
  M[1][0] = m2 * (da * da - da * rr * t.cth) + i2;
  M[1][1] = m2 * da * da + i2;
  M[2][2] = m3 * (sa * sa + sb * sb) + i3;
  M[3][3] = m4 * (e - ea) * (e - ea) + i4;
  M[4][3] = m4 * ((e - ea) * (e - ea) + zt * (e - ea) * t.sph) + i4;
  M[4][4] = m4 * (zt * zt + 2 * zt * (e - ea) * t.sph + (e - ea) * (e - ea)) +
            m5 * (ta * ta + tb * tb) + i4 + i5;
  M[5][5] = m6 * (zf - fa) * (zf - fa) + i6;
  M[6][5] = m6 * ((zf - fa) * (zf - fa) - u * (zf - fa) * t.som) + i6;
  M[6][6] = m6 * ((zf - fa) * (zf - fa) - 2 * u * (zf - fa) * t.som + u * u) +
            m7 * (ua * ua + ub * ub) + i6 + i7;
  M[0][1] = M[1][0];
  M[3][4] = M[4][3];
  M[5][6] = M[6][5];
}

// The spring's generalized force on gamma (andfunc's ff(3)).
inline double spring_force(const double* y) {
  const Trig t(y);
  const double xd = sd * t.cg + sc * t.sg + xb, yd = sd * t.sg - sc * t.cg + yb;
  const double lang = std::sqrt((xd - xc) * (xd - xc) + (yd - yc) * (yd - yc));
  const double force = -c0 * (lang - l0) / lang;
  return force * (xd - xc) * (sc * t.cg - sd * t.sg) + force * (yd - yc) * (sd * t.cg + sc * t.sg);
}

// f(y, v): motor torque, spring, and the velocity terms (andfunc's ff).
inline void forces(const double* y, const double* v, double f[7]) {
  const Trig t(y);
  f[0] = mom - m2 * da * rr * v[1] * (v[1] + 2 * v[0]) * t.sth;
  f[1] = m2 * da * rr * v[0] * v[0] * t.sth;
  f[2] = spring_force(y);
  f[3] = m4 * zt * (e - ea) * v[4] * v[4] * t.cph;
  f[4] = -m4 * zt * (e - ea) * v[3] * (v[3] + 2 * v[4]) * t.cph;
  f[5] = -m6 * u * (zf - fa) * v[6] * v[6] * t.com;
  f[6] = m6 * u * (zf - fa) * v[5] * (v[5] + 2 * v[6]) * t.com;
}

// g(y), the six position constraints (andfunc's g).
inline void constraints(const double* y, double g[6]) {
  const Trig t(y);
  g[0] = rr * t.cb - d * t.cbth - ss * t.sg - xb;
  g[1] = rr * t.sb - d * t.sbth + ss * t.cg - yb;
  g[2] = rr * t.cb - d * t.cbth - e * t.sphd - zt * t.cd - xa;
  g[3] = rr * t.sb - d * t.sbth + e * t.cphd - zt * t.sd - ya;
  g[4] = rr * t.cb - d * t.cbth - zf * t.comep - u * t.sep - xa;
  g[5] = rr * t.sb - d * t.sbth - zf * t.somep + u * t.cep - ya;
}

// G(y) = dg/dy, 6 x 7 row-major (andfunc's gp).
inline void jacobian(const double* y, double G[6][7]) {
  const Trig t(y);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 7; ++j) G[i][j] = 0;
  for (int r = 0; r < 6; r += 2) {  // the K1-K2 chain's E, in each pair of rows
    G[r][0] = -rr * t.sb + d * t.sbth;
    G[r][1] = d * t.sbth;
    G[r + 1][0] = rr * t.cb - d * t.cbth;
    G[r + 1][1] = -d * t.cbth;
  }
  G[0][2] = -ss * t.cg;
  G[1][2] = -ss * t.sg;
  G[2][3] = -e * t.cphd;
  G[2][4] = -e * t.cphd + zt * t.sd;
  G[3][3] = -e * t.sphd;
  G[3][4] = -e * t.sphd - zt * t.cd;
  G[4][5] = zf * t.somep;
  G[4][6] = zf * t.somep - u * t.cep;
  G[5][5] = -zf * t.comep;
  G[5][6] = -zf * t.comep - u * t.sep;
}

// c(y, v) = d^2 g/dt^2 - G w: the terms quadratic in v, differentiating g twice.
inline void quadratic(const double* y, const double* v, double c[6]) {
  const Trig t(y);
  const double bt = v[0] + v[1], pd = v[3] + v[4], oe = v[5] + v[6];
  const double cx = -rr * t.cb * v[0] * v[0] + d * t.cbth * bt * bt;  // K1-K2's E, x
  const double cy = -rr * t.sb * v[0] * v[0] + d * t.sbth * bt * bt;  // and y
  c[0] = cx + ss * t.sg * v[2] * v[2];
  c[1] = cy - ss * t.cg * v[2] * v[2];
  c[2] = cx + e * t.sphd * pd * pd + zt * t.cd * v[4] * v[4];
  c[3] = cy - e * t.cphd * pd * pd + zt * t.sd * v[4] * v[4];
  c[4] = cx + zf * t.comep * oe * oe + u * t.sep * v[6] * v[6];
  c[5] = cy + zf * t.somep * oe * oe - u * t.cep * v[6] * v[6];
}

}  // namespace andrews_ts
