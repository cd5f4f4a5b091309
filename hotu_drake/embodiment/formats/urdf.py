"""URDF export. Actuators come from `<transmission>` elements (read by
Drake and ROS alike); Drake's extensions add rotor inertia, PD gains and
collision filter groups. CURI's base joints hang from the `world` link.
"""

from __future__ import annotations

import math

from hotu_drake.embodiment.collision import filter_groups
from hotu_drake.embodiment.formats.common import color, fmt, header, vec
from hotu_drake.embodiment.spec import EmbodimentSpec, Geometry


def _geometry(g: Geometry) -> str:
    if g.shape == "box":
        return f'<box size="{vec(g.size)}"/>'
    if g.shape == "sphere":
        return f'<sphere radius="{fmt(g.size[0])}"/>'
    return f'<{g.shape} radius="{fmt(g.size[0])}" length="{fmt(g.size[1])}"/>'


def to_urdf(spec: EmbodimentSpec) -> str:
    """The embodiment as a URDF string."""
    out = [
        '<?xml version="1.0"?>',
        f"<!-- {header(spec, 'URDF')} -->",
        f'<robot name="{spec.name}" xmlns:drake="http://drake.mit.edu">',
    ]
    parts = sorted({link.part for link in spec.links})
    for part in parts:
        rgba = vec(color(next(link for link in spec.links if link.part == part)))
        out.append(f'  <material name="{part}"><color rgba="{rgba}"/></material>')
    if not spec.floating_base:
        out.append('  <link name="world"/>')
    for link in spec.links:
        com, inertia = link.mass_properties()
        out += [
            f'  <link name="{link.name}">',
            "    <inertial>",
            f'      <origin xyz="{vec(com)}" rpy="0 0 0"/>',
            f'      <mass value="{fmt(link.mass)}"/>',
            f'      <inertia ixx="{fmt(inertia[0, 0])}" ixy="{fmt(inertia[0, 1])}" '
            f'ixz="{fmt(inertia[0, 2])}" iyy="{fmt(inertia[1, 1])}" '
            f'iyz="{fmt(inertia[1, 2])}" izz="{fmt(inertia[2, 2])}"/>',
            "    </inertial>",
        ]
        for i, g in enumerate(link.visuals):
            out += [
                f'    <visual name="{link.name}_visual_{i}">',
                f'      <origin xyz="{vec(g.position)}" rpy="{vec(g.rpy)}"/>',
                f"      <geometry>{_geometry(g)}</geometry>",
                f'      <material name="{link.part}"/>',
                "    </visual>",
            ]
        for i, g in enumerate(link.collisions):
            out += [
                f'    <collision name="{link.name}_collision_{i}">',
                f'      <origin xyz="{vec(g.position)}" rpy="{vec(g.rpy)}"/>',
                f"      <geometry>{_geometry(g)}</geometry>",
                "    </collision>",
            ]
        out.append("  </link>")
    for j in spec.joints:
        unlimited = math.isinf(j.lower) and math.isinf(j.upper)
        kind = "continuous" if unlimited and j.kind == "revolute" else j.kind
        limits = "" if unlimited else f'lower="{fmt(j.lower)}" upper="{fmt(j.upper)}" '
        out += [
            f'  <joint name="{j.name}" type="{kind}">',
            f'    <parent link="{j.parent}"/>',
            f'    <child link="{j.child}"/>',
            f'    <origin xyz="{vec(j.offset)}" rpy="0 0 0"/>',
            f'    <axis xyz="{vec(j.axis)}"/>',
            f'    <limit {limits}effort="{fmt(j.effort)}" velocity="{fmt(j.velocity)}"/>',
            f'    <dynamics damping="{fmt(j.damping)}"/>',
            "  </joint>",
        ]
    for j in spec.joints:
        out += [
            f'  <transmission name="{j.name}_transmission">',
            "    <type>transmission_interface/SimpleTransmission</type>",
            f'    <joint name="{j.name}">',
            "      <hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>",
            "    </joint>",
            f'    <actuator name="{j.name}_motor">',
            "      <mechanicalReduction>1</mechanicalReduction>",
            f'      <drake:rotor_inertia value="{fmt(j.armature)}"/>',
            '      <drake:gear_ratio value="1"/>',
            f'      <drake:controller_gains p="{fmt(j.kp)}" d="{fmt(j.kd)}"/>',
            "    </actuator>",
            "  </transmission>",
        ]
    for name, members in filter_groups(spec).items():
        out.append(f'  <drake:collision_filter_group name="{name}">')
        out += [f'    <drake:member link="{m}"/>' for m in members]
        out.append(f'    <drake:ignored_collision_filter_group name="{name}"/>')
        out.append("  </drake:collision_filter_group>")
    out += ["</robot>", ""]
    return "\n".join(out)
