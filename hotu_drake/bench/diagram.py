"""Real-time factors of the scenario diagrams and the cost of each added system.

Three diagrams per embodiment and hands variant, each run on one core:

- `standing`: the plant and its PD holding the standing pose;
- `perturbation`: the same while the perturbation scenario throws its cubes
  (legged robots: the shipped `perturb_<robot>` scenario);
- `all_systems`: what a learning step runs: a policy (freshly initialised,
  the network size training uses) setting the PD targets at 30 Hz from the
  ObservationSystem, a held box with a target and the InteractionGraphSystem;
  after every control step the loop reads the observation, the per-part AMP
  observation and the interaction vector s_I, as an environment does.

The per-control-step costs split the `all_systems` loop: `advance` (plant,
PD and the policy's update, inside `AdvanceTo`), then each read, and the
policy network's forward pass timed on its own.
"""

import time

import numpy as np
import torch

from hotu_drake import embodiment as embodiments
from hotu_drake.diagrams import build_simulation
from hotu_drake.learning.checkpoint import save_checkpoint
from hotu_drake.objects import SceneObject
from hotu_drake.scenario import InitialCondition, PolicyCheckpoint, Scenario, load_scenario, shipped_scenarios
from hotu_drake.systems.policy import CONTROL_RATE, policy_for

PERTURBATION_SECONDS = 3.0  # the shipped perturbation scenarios throw at 1 s and 2 s


def _advance(sim, seconds: float) -> float:
    start = time.perf_counter()
    sim.simulator.AdvanceTo(seconds)
    return time.perf_counter() - start


def _held_box(emb) -> SceneObject:
    """A box floating in front of the embodiment at about its hands' height."""
    height = 0.9 * emb.standing_pelvis_height if emb.floating_base else 0.9
    return SceneObject(kind="box", position=[0.6, 0.0, height], held=True, target=[1.5, 1.0, height])


def all_systems_loop(name: str, hands: str, seconds: float, workdir) -> dict:
    """Run the all-systems diagram control step by control step; costs in ms per step."""
    emb = embodiments.load(name, hands)
    network = policy_for(emb)
    checkpoint = save_checkpoint(workdir / f"{name}_{hands}.pt", network, name, hands)
    scenario = Scenario(
        embodiment=name,
        hands=hands,
        initial=InitialCondition(drop_height=0.0),
        control_rate=CONTROL_RATE,
        driver=PolicyCheckpoint(str(checkpoint)),
        objects=[_held_box(emb)],
    )
    sim = build_simulation(scenario, embodiment=emb)
    reads = ["observation", "amp_observation"] + (["interaction"] if "interaction_graph" in sim.systems else [])
    ports = {r: sim.diagram.GetOutputPort(r) for r in reads}
    context = sim.simulator.get_context()
    latents = {part: torch.zeros(size) for part, size in network.config.latent_sizes.items()}
    costs = dict.fromkeys(["advance", *reads, "policy_forward"], 0.0)
    steps = int(round(seconds * CONTROL_RATE))
    for k in range(1, steps + 1):
        costs["advance"] += _advance(sim, k / CONTROL_RATE)
        for read, port in ports.items():
            start = time.perf_counter()
            port.Eval(context)
            costs[read] += time.perf_counter() - start
        observation = torch.as_tensor(ports["observation"].Eval(context), dtype=torch.float32)
        start = time.perf_counter()
        with torch.no_grad():
            network(observation, latents)
        costs["policy_forward"] += time.perf_counter() - start
    loop = sum(v for k, v in costs.items() if k != "policy_forward")
    return {
        "realtime_factor": round(steps / CONTROL_RATE / loop, 2),
        "ms_per_control_step": {k: round(1000 * v / steps, 3) for k, v in costs.items()},
        "fell": sim.fall_check()(sim.plant_context()),
    }


def diagram_costs(name: str, hands: str, seconds: float, workdir) -> dict:
    """Standing, perturbation and all-systems real-time factors of one embodiment."""
    emb = embodiments.load(name, hands)
    standing = build_simulation(
        Scenario(embodiment=name, hands=hands, initial=InitialCondition(drop_height=0.0)), embodiment=emb
    )
    wall = _advance(standing, seconds)
    row = {
        "embodiment": name,
        "hands": hands,
        "dof": emb.part_dof["total"],
        "standing_rtf": round(seconds / wall, 2),
        "standing_ms_per_control_step": round(1000 * wall / (seconds * CONTROL_RATE), 3),
    }
    if f"perturb_{name}" in shipped_scenarios():
        scenario = load_scenario(f"perturb_{name}")
        scenario.hands = hands
        perturbed = build_simulation(scenario, embodiment=emb)
        row["perturbation_rtf"] = round(PERTURBATION_SECONDS / _advance(perturbed, PERTURBATION_SECONDS), 2)
    loop = all_systems_loop(name, hands, seconds, workdir)
    row["all_systems_rtf"] = loop["realtime_factor"]
    row["ms_per_control_step"] = loop["ms_per_control_step"]
    row["all_systems_fell"] = loop["fell"]
    return row


def summary(rows: list[dict]) -> list[str]:
    """Markdown table lines of the figures."""
    lines = [
        "| embodiment | hands | standing RTF | perturbation RTF | all systems RTF | advance | observation "
        "| AMP obs | s_I | policy fwd |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        c = r["ms_per_control_step"]
        lines.append(
            f"| {r['embodiment']} | {r['hands']} | {r['standing_rtf']:.2f} | {r.get('perturbation_rtf', np.nan):.2f} "
            f"| {r['all_systems_rtf']:.2f} | {c['advance']:.2f} | {c['observation']:.3f} | {c['amp_observation']:.3f} "
            f"| {c.get('interaction', np.nan):.3f} | {c['policy_forward']:.3f} |"
        )
    return lines
