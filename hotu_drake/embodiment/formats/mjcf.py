"""MJCF export, so the same robot loads in MuJoCo.

Bodies nest along the kinematic tree with world-aligned frames; the built-in
PD becomes a `position` actuator with the same gains and force range; the
ignored self-collision pairs become `<exclude>` elements. Visual geoms are
in group 1 and do not collide; collision geoms are in group 3. The file
sets MuJoCo's `implicitfast` integrator at a 2 ms step, which keeps the
stiff servos of the light finger and wrist links stable.
"""

from __future__ import annotations

import itertools

import numpy as np

from hotu_drake.embodiment.collision import filter_groups
from hotu_drake.embodiment.formats.common import color, fmt, header, vec
from hotu_drake.embodiment.spec import EmbodimentSpec, Geometry, JointSpec, LinkSpec, rotation_from_rpy


def _quat(rpy) -> str:
    r = rotation_from_rpy(rpy)
    w = np.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2.0
    if w > 1e-6:
        q = (w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w))
    else:  # 180 degree turn: pick the largest diagonal
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = np.sqrt(max(0.0, 1.0 + r[i, i] - r[j, j] - r[k, k])) * 2.0
        v = [0.0, 0.0, 0.0]
        v[i] = s / 4.0
        v[j] = (r[j, i] + r[i, j]) / s
        v[k] = (r[k, i] + r[i, k]) / s
        q = ((r[k, j] - r[j, k]) / s, *v)
    return vec(q)


def _geom(name: str, g: Geometry, extra: str) -> str:
    if g.shape == "box":
        size = vec(s / 2.0 for s in g.size)
    elif g.shape == "sphere":
        size = fmt(g.size[0])
    else:
        size = f"{fmt(g.size[0])} {fmt(g.size[1] / 2.0)}"
    return f'<geom name="{name}" type="{g.shape}" size="{size}" pos="{vec(g.position)}" quat="{_quat(g.rpy)}" {extra}/>'


def _joint(j: JointSpec) -> str:
    kind = "hinge" if j.kind == "revolute" else "slide"
    unlimited = np.isinf(j.lower) and np.isinf(j.upper)
    limits = "" if unlimited else f'range="{fmt(j.lower)} {fmt(j.upper)}" '
    return (
        f'<joint name="{j.name}" type="{kind}" axis="{vec(j.axis)}" {limits}'
        f'actuatorfrcrange="{fmt(-j.effort)} {fmt(j.effort)}" armature="{fmt(j.armature)}" '
        f'damping="{fmt(j.damping)}"/>'
    )


def _ctrlrange(j: JointSpec) -> str:
    if np.isinf(j.lower) and np.isinf(j.upper):
        return ""
    return f' ctrlrange="{fmt(j.lower)} {fmt(j.upper)}"'


def _body(spec: EmbodimentSpec, link: LinkSpec, joint: JointSpec | None, children, depth: int) -> list[str]:
    pad = "  " * depth
    pos = joint.offset if joint is not None else link.origin
    com, inertia = link.mass_properties()
    full = vec([inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]])
    out = [f'{pad}<body name="{link.name}" pos="{vec(pos)}">']
    if joint is not None:
        out.append(f"{pad}  {_joint(joint)}")
    elif spec.floating_base:
        out.append(f'{pad}  <freejoint name="root"/>')
    out.append(f'{pad}  <inertial pos="{vec(com)}" mass="{fmt(link.mass)}" fullinertia="{full}"/>')
    visual = f'rgba="{vec(color(link))}" group="1" contype="0" conaffinity="0" mass="0"'
    for i, g in enumerate(link.visuals):
        out.append(f"{pad}  " + _geom(f"{link.name}_visual_{i}", g, visual))
    collision = 'group="3" rgba="0.5 0.5 0.5 0.3" mass="0"'
    for i, g in enumerate(link.collisions):
        out.append(f"{pad}  " + _geom(f"{link.name}_collision_{i}", g, collision))
    for child_joint in children.get(link.name, []):
        out += _body(spec, spec.link(child_joint.child), child_joint, children, depth + 1)
    out.append(f"{pad}</body>")
    return out


def to_mjcf(spec: EmbodimentSpec) -> str:
    """The embodiment as an MJCF string."""
    children: dict[str, list[JointSpec]] = {}
    for j in spec.joints:
        children.setdefault(j.parent, []).append(j)
    out = [
        f'<mujoco model="{spec.name}">',
        f"  <!-- {header(spec, 'MJCF')} -->",
        '  <compiler angle="radian" autolimits="true"/>',
        # Stiff position servos on light links need MuJoCo's implicit
        # integrator; at the default Euler step the UDH's wrists chatter.
        '  <option timestep="0.002" integrator="implicitfast"/>',
        "  <worldbody>",
    ]
    if spec.floating_base:
        out += _body(spec, spec.root, None, children, 2)
    else:
        for j in children["world"]:
            out += _body(spec, spec.link(j.child), j, children, 2)
    out.append("  </worldbody>")
    pairs = set()
    for members in filter_groups(spec).values():
        pairs.update(tuple(sorted(p)) for p in itertools.combinations(members, 2))
    if pairs:
        out.append("  <contact>")
        out += [f'    <exclude body1="{a}" body2="{b}"/>' for a, b in sorted(pairs)]
        out.append("  </contact>")
    out.append("  <actuator>")
    for j in spec.joints:
        out.append(
            f'    <position name="{j.name}" joint="{j.name}" kp="{fmt(j.kp)}" kv="{fmt(j.kd)}" '
            f'forcerange="{fmt(-j.effort)} {fmt(j.effort)}"{_ctrlrange(j)}/>'
        )
    out += ["  </actuator>", "</mujoco>", ""]
    return "\n".join(out)
