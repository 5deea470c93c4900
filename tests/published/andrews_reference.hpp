// Published data of Andrews' squeezing mechanism (IFToMM A03), in the test set's
// coordinates y(1..7) = (beta, Theta, gamma, Phi, delta, Omega, epsilon).
//
// Source: Test Set for IVP Solvers (F. Mazzia, C. Magherini, University of Bari; formerly
// CWI, W. M. Lioen and J. J. B. de Swart), problem "andrews", file
// src/problems/andrews.f, revision "andrews.F,v 1.2 2006/10/02"; the same file ships in the
// R package deTestSet (cran/deTestSet, src/andrews.f and R/andrews.R).  Its model is
// Hairer & Wanner, "Solving Ordinary Differential Equations II", Section VII.7, eq. (7.11).
//  - parameters: subroutine andpar / andfunc's common block (also deTestSet's R/andrews.R);
//  - consistent initial values: the test set's init (andrews.f, and deTestSet's yini):
//    positions, velocities 0, accelerations w = y(15..21), multipliers lambda = y(22..27);
//  - reference solution at t = 0.03: subroutine andsoln ("computed at Cray C90, using Cray
//    double precision: Solving Andrews' squeezing mechanism using PSIDE, rtol = atol =
//    1d-14"), all 27 components.
#pragma once

namespace andrews_ref {

// Parameters (SI units).
inline constexpr double m1 = .04325, m2 = .00365, m3 = .02373, m4 = .00706, m5 = .07050,
                        m6 = .00706, m7 = .05498;
inline constexpr double xa = -.06934, ya = -.00227, xb = -0.03635, yb = .03273, xc = .014,
                        yc = .072;
inline constexpr double c0 = 4530;
inline constexpr double i1 = 2.194e-6, i2 = 4.410e-7, i3 = 5.255e-6, i4 = 5.667e-7,
                        i5 = 1.169e-5, i6 = 5.667e-7, i7 = 1.912e-5;
inline constexpr double d = 28e-3, da = 115e-4, e = 2e-2, ea = 1421e-5, rr = 7e-3, ra = 92e-5,
                        l0 = 7785e-5;
inline constexpr double ss = 35e-3, sa = 1874e-5, sb = 1043e-5, sc = 18e-3, sd = 2e-2,
                        ta = 2308e-5, tb = 916e-5;
inline constexpr double u = 4e-2, ua = 1228e-5, ub = 449e-5, zf = 2e-2, zt = 4e-2,
                        fa = 1421e-5, mom = 33e-3;

// Consistent initial state at t = 0 (test set's init): angles, velocities zero.
inline constexpr double q0[7] = {
    -0.0617138900142764496358948458001,  // beta
    0.0,                                 // Theta
    0.455279819163070380255912382449,    // gamma
    0.222668390165885884674473185609,    // Phi
    0.487364979543842550225598953530,    // delta
    -0.222668390165885884674473185609,   // Omega
    1.23054744454982119249735015568};    // epsilon
inline constexpr double w0[7] = {  // accelerations at t = 0
    14222.4439199541138705911625887, -10666.8329399655854029433719415, 0, 0, 0, 0, 0};
inline constexpr double lambda0[6] = {  // multipliers at t = 0
    98.5668703962410896057654982170, -6.12268834425566265503114393122, 0, 0, 0, 0};

// Reference solution at t = 0.03 (andsoln).
inline constexpr double t_end = 0.03;
inline constexpr double q_end[7] = {
    0.1581077119629904e+2,  -0.1575637105984298e+2, 0.4082224013073101e-1,
    -0.5347301163226948e+0, 0.5244099658805304e+0,  0.5347301163226948e+0,
    0.1048080741042263e+1};
inline constexpr double v_end[7] = {
    0.1139920302151208e+4, -0.1424379294994111e+4, 0.1103291221937134e+2,
    0.1929337464421385e+2, 0.5735699284790808e+0,  -0.1929337464421385e+2,
    0.3231791658026955e+0};
inline constexpr double w_end[7] = {
    -0.2463176316945196e+5, 0.5185037701610329e+5, 0.3241025686413781e+6,
    0.5667493645176213e+6,  0.1674362929479361e+5, -0.5667493645176222e+6,
    0.9826520791458422e+4};
inline constexpr double lambda_end[6] = {
    0.1991753333731910e+3, -0.2975531228015052e+2, 0.2306654119098399e+2,
    0.3145271365475927e+2, 0.2264249232082739e+2,  0.1161740700019673e+2};

// jrgen's user order (models/andrews_squeezer.urdf) is (beta, Theta, gamma, delta, Phi,
// epsilon, Omega): q_jr[i] = y[perm[i]].
inline constexpr int perm[7] = {0, 1, 2, 4, 3, 6, 5};

}  // namespace andrews_ref
