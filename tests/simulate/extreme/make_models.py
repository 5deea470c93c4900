#!/usr/bin/env python3
"""Writes the generated models of tests/simulate/extreme/ (the double
pendulums with mass ratios and the rope); the others are written by hand.
Run from this directory: python3 make_models.py"""


def link(name, m, com, r2):
    inertia = m * r2
    return f'''  <link name="{name}">
    <inertial>
      <origin xyz="{com}"/>
      <mass value="{m:g}"/>
      <inertia ixx="{inertia:g}" ixy="0" ixz="0" iyy="{inertia:g}" iyz="0" izz="{inertia:g}"/>
    </inertial>
  </link>
'''


def double_pendulum(name, m1, m2, comment):
    s = f'''<?xml version="1.0"?>
<!-- {comment}
     Planar double pendulum (axes y, gravity -z), links 1 m, each body a
     point-like mass at the link's end with radius of gyration 0.1 m.
     Upper mass {m1:g} kg, lower (tip) mass {m2:g} kg.  No damping: energy
     is conserved.  Written by make_models.py, for
     tests/simulate/extreme_test.cpp (docs/simulation.md, "Extreme cases in time"). -->
<robot name="{name}">
  <link name="world"/>
'''
    s += link("upper", m1, "0 0 -1", 0.01) + link("lower", m2, "0 0 -1", 0.01)
    s += '''  <joint name="shoulder" type="continuous">
    <parent link="world"/>
    <child link="upper"/>
    <axis xyz="0 1 0"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="upper"/>
    <child link="lower"/>
    <origin xyz="0 0 -1"/>
    <axis xyz="0 1 0"/>
  </joint>
</robot>
'''
    with open(name + ".urdf", "w") as f:
        f.write(s)


def rope(n):
    s = f'''<?xml version="1.0"?>
<!-- A rope of {n} links (written by make_models.py): revolute joints about
     y (gravity -z), each link {1/n:g} m long with its mass {1/n:g} kg at its
     end (radius of gyration 1/10 of the link), total 1 m and 1 kg.  No
     damping: energy is conserved.  For tests/simulate/extreme_test.cpp. -->
<robot name="rope{n}">
  <link name="world"/>
'''
    for i in range(n):
        s += link(f"l{i}", 1.0 / n, f"0 0 {-1.0 / n:g}", (0.1 / n) ** 2)
    for i in range(n):
        parent = "world" if i == 0 else f"l{i - 1}"
        origin = "0 0 0" if i == 0 else f"0 0 {-1.0 / n:g}"
        s += f'''  <joint name="j{i}" type="continuous">
    <parent link="{parent}"/>
    <child link="l{i}"/>
    <origin xyz="{origin}"/>
    <axis xyz="0 1 0"/>
  </joint>
'''
    s += "</robot>\n"
    with open(f"rope{n}.urdf", "w") as f:
        f.write(s)


double_pendulum("dp_light_tip_1e6", 1, 1e-6, "Mass ratio 1e6, light tip.")
double_pendulum("dp_light_tip_1e9", 1, 1e-9, "Mass ratio 1e9, light tip.")
double_pendulum("dp_light_tip_1e12", 1, 1e-12, "Mass ratio 1e12, light tip.")
double_pendulum("dp_heavy_tip_1e6", 1, 1e6, "Mass ratio 1e6, heavy tip.")
double_pendulum("dp_heavy_tip_1e9", 1, 1e9, "Mass ratio 1e9, heavy tip.")
double_pendulum("dp_light_tip_1e15", 1, 1e-15,
                "Mass ratio 1e15, light tip: beyond the generated solver's digit test (status 1).")
rope(50)
