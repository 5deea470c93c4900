#!/usr/bin/env python3
"""Writes models/iftomm_a02_nfourbar.urdf: IFToMM benchmark A02, the N four-bar
mechanism (N = 40 by default).  Run from the repository root:

    python3 scripts/make_nfourbar.py [N] > models/iftomm_a02_nfourbar.urdf

The file is committed; this script only documents how it was made."""
import sys

N = int(sys.argv[1]) if len(sys.argv) > 1 else 40
# Uniform slender bar of 1 kg, 1 m: I = m L^2 / 12 about the perpendicular axes
# through its centre, 0 about its own axis.
I = 1.0 / 12.0

HEADER = f"""<?xml version="1.0"?>
<!--
  IFToMM benchmark A02: the N four-bar mechanism, N = {N}.  Written by
  scripts/make_nfourbar.py {N}; do not edit by hand.
  Source: the IFToMM Library of Computational Benchmark Problems (M. Gonzalez et al.,
  Multibody System Dynamics 16 (2006) 179-190), problem page
  http://lim.ii.udc.es/mbsbenchmark/dist/A02/A02_specification.xml:
    "The one degree-of-freedom assembly of N four-bar linkages is composed by 2N+1 links of
     1 m length with a uniformly distributed mass of 1 kg ... gravity (9.81 N/kg acting in
     the negative y direction) ... When the mechanism reaches the horizontal position, the
     number of degrees of freedom instantaneously increases from 1 to N+1 ... duration of
     20 s ... Initially, the system (particularized for N=40) is in the position shown in
     the figure, and the velocity of the x-coordinate of point B0 is 1 m/s."
    Reference: time history of the position and velocity of B0; maximum allowed errors 1e-1
    (low) and 1e-3 (high precision), 400 output steps, threshold 1e-3.
  The figure: fixed pivots A_i = (i, 0), i = 0..N; vertical cranks A_i B_i, B_i = (i, 1) at
  the start; horizontal couplers B_(i-1) B_i.  World frame: the benchmark's (x right, y up).
  Generate with  - -gravity 0,-9.81,0  (the tests do).

  Tree: every crank on the ground (joint crank_i at A_i), coupler_i on crank_(i-1) at
  B_(i-1) (joint coupler_i); the cut B_i (revolute, inline <loop_joint>) pins coupler_i's
  right end to crank_i.  Each cut keeps 2 of its 5 rows (the planar ones): nc = 2N.
  Coordinates, user order (depth first, siblings in document order):
  crank_0, coupler_1, crank_1, coupler_2, ..., coupler_N, crank_N: q[2i] = crank_i,
  q[2i-1] = coupler_i.  crank_i: angle of the crank from the
  vertical, counter-clockwise; coupler_i: angle of the coupler relative to crank_(i-1).
  On the parallelogram motion every crank has the same angle th and every coupler -th;
  B0 = (-sin th, cos th), so "x-velocity of B0 is 1 m/s" is th' = -1 rad/s (couplers +1).
  The start is the figure, q = 0 (assembled as drawn).
-->
<robot name="iftomm_a02_nfourbar">
  <link name="ground"/>"""


def crank(i):
    return f"""
  <link name="crank_{i}">
    <inertial>
      <origin xyz="0 0.5 0"/>
      <mass value="1"/>
      <inertia ixx="{I:.17g}" ixy="0" ixz="0" iyy="0" iyz="0" izz="{I:.17g}"/>
    </inertial>
  </link>
  <joint name="crank_{i}" type="continuous">
    <parent link="ground"/>
    <child link="crank_{i}"/>
    <origin xyz="{i} 0 0"/>
    <axis xyz="0 0 1"/>
  </joint>"""


def coupler(i):
    return f"""
  <link name="coupler_{i}">
    <inertial>
      <origin xyz="0.5 0 0"/>
      <mass value="1"/>
      <inertia ixx="0" ixy="0" ixz="0" iyy="{I:.17g}" iyz="0" izz="{I:.17g}"/>
    </inertial>
  </link>
  <joint name="coupler_{i}" type="continuous">
    <parent link="crank_{i - 1}"/>
    <child link="coupler_{i}"/>
    <origin xyz="0 1 0"/>
    <axis xyz="0 0 1"/>
  </joint>"""


def cut(i):
    return f"""
  <loop_joint name="B_{i}" type="revolute">
    <parent link="crank_{i}"/>
    <child link="coupler_{i}"/>
    <origin xyz="0 1 0"/>
    <child_origin xyz="1 0 0"/>
    <axis xyz="0 0 1"/>
  </loop_joint>"""


parts = [HEADER, crank(0)]
for i in range(1, N + 1):
    parts += [coupler(i), crank(i)]
parts += [cut(i) for i in range(1, N + 1)]
parts.append("\n</robot>\n")
sys.stdout.write("".join(parts))
