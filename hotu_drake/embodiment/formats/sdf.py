"""SDFormat 1.9 export, with Drake's actuator, rotor and PD gain extensions.

Drake creates an actuator for every joint with a non-zero effort limit and
turns on its built-in PD from `drake:controller_gains`.
"""

from __future__ import annotations

import math
from xml.sax.saxutils import quoteattr

from hotu_drake.embodiment.collision import filter_groups
from hotu_drake.embodiment.formats.common import color, fmt, header, vec
from hotu_drake.embodiment.spec import EmbodimentSpec, Geometry


def geometry_sdf(g: Geometry) -> str:
    """The SDFormat `<geometry>` content of a primitive."""
    if g.shape == "box":
        return f"<box><size>{vec(g.size)}</size></box>"
    if g.shape == "sphere":
        return f"<sphere><radius>{fmt(g.size[0])}</radius></sphere>"
    radius, length = g.size
    return f"<{g.shape}><radius>{fmt(radius)}</radius><length>{fmt(length)}</length></{g.shape}>"


def _range(j) -> str:
    """Position limits; an unlimited joint (CURI's base yaw) leaves them out."""
    if math.isinf(j.lower) and math.isinf(j.upper):
        return ""
    return f"<lower>{fmt(j.lower)}</lower><upper>{fmt(j.upper)}</upper>"


def to_sdf(spec: EmbodimentSpec, controller_gains: bool = True) -> str:
    """The embodiment as an SDFormat string.

    Without `controller_gains` the actuators carry no built-in PD: a plant
    step then applies exactly the actuation input (for an explicit PD).
    """
    out = [
        '<?xml version="1.0"?>',
        f"<!-- {header(spec, 'SDFormat 1.9')} -->",
        '<sdf version="1.9" xmlns:drake="http://drake.mit.edu">',
        f'  <model name="{spec.name}">',
    ]
    for link in spec.links:
        com, inertia = link.mass_properties()
        out += [
            f'    <link name="{link.name}">',
            f"      <pose>{vec(link.origin)} 0 0 0</pose>",
            "      <inertial>",
            f"        <pose>{vec(com)} 0 0 0</pose>",
            f"        <mass>{fmt(link.mass)}</mass>",
            "        <inertia>"
            f"<ixx>{fmt(inertia[0, 0])}</ixx><ixy>{fmt(inertia[0, 1])}</ixy>"
            f"<ixz>{fmt(inertia[0, 2])}</ixz><iyy>{fmt(inertia[1, 1])}</iyy>"
            f"<iyz>{fmt(inertia[1, 2])}</iyz><izz>{fmt(inertia[2, 2])}</izz></inertia>",
            "      </inertial>",
        ]
        rgba = vec(color(link))
        for i, g in enumerate(link.visuals):
            out += [
                f'      <visual name="{link.name}_visual_{i}">',
                f"        <pose>{vec(g.position)} {vec(g.rpy)}</pose>",
                f"        <geometry>{geometry_sdf(g)}</geometry>",
                f"        <material><diffuse>{rgba}</diffuse></material>",
                "      </visual>",
            ]
        for i, g in enumerate(link.collisions):
            out += [
                f'      <collision name="{link.name}_collision_{i}">',
                f"        <pose>{vec(g.position)} {vec(g.rpy)}</pose>",
                f"        <geometry>{geometry_sdf(g)}</geometry>",
                "      </collision>",
            ]
        out.append("    </link>")
    for j in spec.joints:
        parent = "world" if j.parent == "world" else j.parent
        out += [
            f'    <joint name="{j.name}" type="{j.kind}">',
            f"      <parent>{parent}</parent>",
            f"      <child>{j.child}</child>",
            "      <axis>",
            f"        <xyz>{vec(j.axis)}</xyz>",
            f"        <limit>{_range(j)}<effort>{fmt(j.effort)}</effort><velocity>{fmt(j.velocity)}</velocity></limit>",
            f"        <dynamics><damping>{fmt(j.damping)}</damping></dynamics>",
            "      </axis>",
            f"      <drake:rotor_inertia>{fmt(j.armature)}</drake:rotor_inertia>",
            "      <drake:gear_ratio>1</drake:gear_ratio>",
            *(
                [f"      <drake:controller_gains p={quoteattr(fmt(j.kp))} d={quoteattr(fmt(j.kd))}/>"]
                if controller_gains
                else []
            ),
            "    </joint>",
        ]
    for name, members in filter_groups(spec).items():
        out.append(f'    <drake:collision_filter_group name="{name}">')
        out += [f"      <drake:member>{m}</drake:member>" for m in members]
        out.append(f"      <drake:ignored_collision_filter_group>{name}</drake:ignored_collision_filter_group>")
        out.append("    </drake:collision_filter_group>")
    out += ["  </model>", "</sdf>", ""]
    return "\n".join(out)
