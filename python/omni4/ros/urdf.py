"""The robot description (URDF) of any layout, for robot_state_publisher: the shipped
omni4.urdf's body and, per wheel of an omni4.wheels.Wheels, a link and a continuous joint at
its angle, distance and height r, named as omni4-ros's /joint_states (the paper's layout: the
four names of omni4.urdf; another: wheel_0_joint .. wheel_{n-1}_joint, links wheel_0 ..). Each
joint's axis points radially outward, so a positive joint speed moves the rim
counter-clockwise (docs/kinematics.md)."""
import math

from ..wheels import Wheels

BODY = """  <material name="body"><color rgba="0.3 0.3 0.35 1"/></material>
  <material name="wheel"><color rgba="0.1 0.1 0.1 1"/></material>
  <link name="base_link">
    <visual><origin xyz="0 0 0.0625"/><geometry><cylinder radius="{body_r:.6f}" length="0.06"/></geometry><material name="body"/></visual>
    <collision><origin xyz="0 0 0.0625"/><geometry><cylinder radius="{body_r:.6f}" length="0.06"/></geometry></collision>
    <inertial><origin xyz="0 0 0.0325"/><mass value="2.34"/><inertia ixx="0.012" ixy="0" ixz="0" iyy="0.012" iyz="0" izz="0.0228"/></inertial>
  </link>
"""
WHEEL = """  <link name="{link}">
    <visual><origin rpy="0 1.570796 0"/><geometry><cylinder radius="{r:.6f}" length="0.02"/></geometry><material name="wheel"/></visual>
    <collision><origin rpy="0 1.570796 0"/><geometry><cylinder radius="{r:.6f}" length="0.02"/></geometry></collision>
    <inertial><mass value="0.05"/><inertia ixx="2.6e-5" ixy="0" ixz="0" iyy="1.5e-5" iyz="0" izz="1.5e-5"/></inertial>
  </link>
  <!-- wheel {j} at {deg:g} deg from v, distance {d:g} m; axis radial outward -->
  <joint name="{joint}" type="continuous">
    <parent link="base_link"/><child link="{link}"/>
    <origin xyz="{x:.6f} {y:.6f} {r:.6f}" rpy="0 0 {a:.6f}"/>
    <axis xyz="1 0 0"/>
  </joint>
"""


def urdf(wheels=None):
    """The URDF text of wheels (None: the paper's layout, Table III)."""
    wheels = wheels or Wheels.paper_layout()
    names = wheels.joint_names()
    parts = ['<?xml version="1.0"?>\n<robot name="omni4">\n',
             BODY.format(body_r=0.865 * max(wheels.distance_m))]
    for j, ((x, y), a, d, r) in enumerate(zip(wheels.positions(), wheels.angle_rad,
                                                wheels.distance_m, wheels.radius_m)):
        parts.append(WHEEL.format(link=names[j][:-len("_joint")], joint=names[j], j=j,
                                  deg=math.degrees(a), d=d, x=x, y=y, r=r,
                                  a=math.remainder(a, 2 * math.pi) % (2 * math.pi)))
    parts.append("</robot>\n")
    return "".join(parts)
