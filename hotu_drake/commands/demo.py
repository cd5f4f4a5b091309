"""The main demo: `python -m hotu_drake.demo [--out DIR]`.

Builds the six embodiments, prints their per-part DoF table and writes
`DIR/gallery.html`, a self-contained Meshcat page of the six standing side
by side, coloured by functional part. Then retargets two generated
demonstrations, a walk and a box carry, onto all six (human -> UDH ->
robots) and writes their side-by-side replays `DIR/walk.html` and
`DIR/box_carry.html` (the UDH with its fingers, the robots without, to keep
the pages light) and the clips under `DIR/clips/`. Last, it runs the
cube-perturbation scenario of each legged robot and writes its Meshcat
replay `DIR/perturb_<robot>.html`; and runs the learned policies shipped in
`systems/policies/` (the `learned_<name>` scenarios), writing
`DIR/learned_<name>.html`; and the robots the whole-body controller keeps
walking (the `whole_body_walk_<robot>` scenarios: 10 s of the library walk,
performed in the simulator), writing `DIR/whole_body_walk_<robot>.html`.
"""

import sys
from pathlib import Path

import numpy as np

from hotu_drake import embodiment
from hotu_drake.cli import ArgumentParser, run_cli
from hotu_drake.errors import InputError
from hotu_drake.gallery import write_gallery
from hotu_drake.models import dof_table, format_table
from hotu_drake.motion.library import generate
from hotu_drake.retarget.pipeline import ROBOTS, retarget_onto, to_udh
from hotu_drake.retarget.replay import write_replay

DEMO_MOTIONS = ("walk", "box_carry")


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m hotu_drake.demo", description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out", help="output folder (default: out)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: is a file; give a folder")

    print("Functional-part DoF of the six embodiments (full hands):")
    print(format_table(dof_table("full")))
    for name in embodiment.EMBODIMENT_NAMES:
        emb = embodiment.load(name, "none")
        stance = (
            f"standing pelvis height {emb.standing_pelvis_height:.3f} m"
            if emb.floating_base
            else f"holonomic base ({', '.join(emb.base_joints)})"
        )
        print(f"  {name:7s} no-hands DoF {emb.part_dof['total']:3d}, {stance}")
    gallery = write_gallery(out / "gallery.html")
    print(f"wrote {gallery} (open it in a browser)")
    for motion in DEMO_MOTIONS:
        source = generate(motion)
        robots = retarget_onto(source, ROBOTS, "none")
        clips = [to_udh(source, "full").clip] + [robots[robot].clip for robot in ROBOTS]
        for clip in clips:
            clip.save(out / "clips" / f"{motion}_{clip.embodiment}.npz")
        replay = write_replay(out / f"{motion}.html", clips, source)
        print(f"wrote {replay}: {motion} retargeted onto {', '.join(c.embodiment for c in clips)}")
    write_perturbation_replays(out)
    write_learned_replays(out)
    write_scenario_replays(out, "whole_body_walk_", "the library walk under the whole-body controller")
    return 0


def write_perturbation_replays(out: Path) -> list[Path]:
    """Run the `perturb_<robot>` scenario of every legged robot, recording Meshcat."""
    from pydrake.geometry import StartMeshcat

    from hotu_drake.diagrams import run_scenario as run
    from hotu_drake.io import write_text_atomic
    from hotu_drake.scenario import load_scenario, shipped_scenarios

    meshcat = StartMeshcat()
    written = []
    shipped = shipped_scenarios()
    for name in embodiment.EMBODIMENT_NAMES:
        if f"perturb_{name}" not in shipped:
            continue
        meshcat.Delete()
        figures = run(load_scenario(f"perturb_{name}"), meshcat=meshcat)
        written.append(write_text_atomic(out / f"perturb_{name}.html", meshcat.StaticHtml()))
        outcome = "fell" if figures["fell"] else "stayed up"
        print(f"wrote {written[-1]}: cubes thrown at {name}, which {outcome}")
    return written


def write_learned_replays(out: Path) -> list[Path]:
    """Run each shipped `learned_<name>` scenario (a policy checkpoint shipped
    in systems/policies/), recording Meshcat into `DIR/learned_<name>.html`."""
    return write_scenario_replays(out, "learned_", "a learned policy")


def write_scenario_replays(out: Path, prefix: str, what: str) -> list[Path]:
    """Run each shipped scenario whose name starts with `prefix`, recording
    Meshcat into `DIR/<name>.html`, and say whether `what` stayed up."""
    from pydrake.geometry import StartMeshcat

    from hotu_drake.diagrams import run_scenario as run
    from hotu_drake.io import write_text_atomic
    from hotu_drake.scenario import load_scenario, shipped_scenarios

    meshcat = StartMeshcat()
    written = []
    for name in sorted(n for n in shipped_scenarios() if n.startswith(prefix)):
        meshcat.Delete()
        figures = run(load_scenario(name), meshcat=meshcat)
        frame_travel(meshcat, figures["root_travel_m"])
        written.append(write_text_atomic(out / f"{name}.html", meshcat.StaticHtml()))
        outcome = "fell" if figures["fell"] else "stayed up"
        print(f"wrote {written[-1]}: {what} ({name}), which {outcome}")
    return written


def frame_travel(meshcat, travel: float) -> None:
    """Look from the side at a robot that walked `travel` metres along +x
    (the library's walks go that way), so the replay shows it all along its
    path rather than leaving the view; a robot that stayed put keeps
    Meshcat's own camera."""
    if travel < 0.5:
        return
    middle = travel / 2.0
    meshcat.SetCameraPose(np.array([middle, -max(3.0, travel), 1.6]), np.array([middle, 0.0, 0.6]))


if __name__ == "__main__":
    sys.exit(run_cli(main))
