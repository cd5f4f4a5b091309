"""Evaluating a behavior policy: falls, style, and closeness to the references.

`evaluate` runs seeded episodes (each to its end or `max_steps`) with the
deterministic policy (the mean action), its latents drawn from the prior
and resampled as in training, and measures:

- `fall_rate`: the share of episodes that ended by a fall;
- `normalized_return`: the mean per-step style reward in [0, 1], as the
  trained discriminators judge it (combined over the groups as in training);
- `joint_distance_deg`: per functional part, the mean over policy frames of
  the distance (RMS over the part's joints, degrees) to the nearest frame of
  the run's reference clips: an independent measure of similarity that no
  network judges;
- `coverage_deg`: the other direction, per part, the mean over the
  reference frames of the distance to the nearest policy frame: how much
  of the reference motion the policy shows. A robot holding one pose of a
  clip is near that clip (small `joint_distance_deg`) but covers little of
  it;
- `motions`: per reference motion, the share of policy frames nearest to it
  (over all joints) and the mean style reward of those frames.

`standing_policy` gives the same figures for a robot that only holds its
standing pose: the baseline a learned motion must beat.

A policy cloned from the whole-body controller (`dagger`) is judged by
what it does instead of by judges: `follow_clips` runs it from each
clip's start (or from the standing pose, `environment.standing_follow`)
and measures its falls, the pelvis' travel against the reference's and
its coverage of the clip's frames, and `clone_report` sets it beside
the teacher itself and the robot standing.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hotu_drake.learning.demonstrations import Demonstrations
from hotu_drake.learning.latents import LatentSchedule

HELD_LIFT = 0.05  # m: an object this far above where it started is held (`bench grasps`' rule, without its contact)
Policy = Callable[[np.ndarray, dict[str, np.ndarray]], np.ndarray]


def standing_policy(action: np.ndarray) -> Policy:
    """A policy that always asks for `action` (the standing pose's); also a
    `TaskController` (it ignores whatever else it is given)."""

    def act(observations: np.ndarray, *_) -> np.ndarray:
        return np.tile(np.asarray(action, dtype=np.float32), (len(observations), 1))

    return act


def evaluate(
    envs,
    policy: Policy,
    demonstrations: Demonstrations,
    joint_columns: np.ndarray,
    style_reward: Callable[[dict[str, np.ndarray]], np.ndarray],
    episodes: int = 20,
    seed: int = 0,
    latent_groups: list[str] | None = None,
    latent_size: int = 0,
    resample: tuple[int, int] = (1, 150),
) -> dict:
    """The figures of the module docstring over the first `episodes`
    episodes to end in `envs` (a vector environment, reset with `seed`).

    `joint_columns` are the observation's columns holding the joint
    positions (in `demonstrations.joint_names` order); `style_reward` maps
    `info["amp"]` to the combined style reward per environment."""
    rng = np.random.default_rng(seed)
    n = envs.num_envs
    latents = LatentSchedule(latent_groups or [], latent_size, n, resample[0], resample[1], rng)
    observations, _ = envs.reset(seed=seed)
    falls, lengths, frames, rewards = 0, [], [], []
    running_frames: list[list[np.ndarray]] = [[] for _ in range(n)]
    running_rewards: list[list[float]] = [[] for _ in range(n)]
    while len(lengths) < episodes:
        action = policy(observations, latents.current())
        observations, _, terminated, truncated, info = envs.step(action)
        done = terminated | truncated
        amp = {key: np.array(v) for key, v in info["amp"].items() if not key.startswith("_")}
        after = observations.copy()
        for i in np.flatnonzero(done):  # the ended episode's last state
            after[i] = info["final_obs"][i]
            for key in amp:
                amp[key][i] = info["final_info"]["amp"][key][i]
        reward = style_reward(amp)
        for i in range(n):
            running_frames[i].append(after[i, joint_columns])
            running_rewards[i].append(float(reward[i]))
        for i in np.flatnonzero(done):
            if len(lengths) < episodes:
                falls += int(terminated[i])
                lengths.append(len(running_frames[i]))
                frames.extend(running_frames[i])
                rewards.extend(running_rewards[i])
            running_frames[i], running_rewards[i] = [], []
        latents.step(done)
    report = {
        "episodes": len(lengths),
        "fall_rate": falls / len(lengths),
        "mean_episode_steps": float(np.mean(lengths)),
        "normalized_return": float(np.mean(rewards)),
        "frames": len(frames),
    }
    return report | similarity(np.array(frames), np.array(rewards), demonstrations)


def similarity(frames: np.ndarray, rewards: np.ndarray, demonstrations: Demonstrations) -> dict:
    """Per-part nearest-reference-frame distances (degrees) of policy joint
    frames, the reference's coverage by them, and each motion's share of
    the frames nearest to it."""
    names = list(demonstrations.motions)
    reference = np.concatenate([demonstrations.motions[m].joints for m in names])
    owner = np.concatenate([np.full(demonstrations.motions[m].num_frames, i) for i, m in enumerate(names)])
    out: dict = {"joint_distance_deg": {}, "coverage_deg": {}}
    for part, joints in demonstrations.part_joints.items():
        if not joints:
            continue
        d = _nearest_distance(frames[:, joints], reference[:, joints])
        out["joint_distance_deg"][part] = float(np.degrees(d.mean()))
        out["coverage_deg"][part] = float(np.degrees(_nearest_distance(reference[:, joints], frames[:, joints]).mean()))
    everything = np.arange(frames.shape[1])
    nearest = _nearest_index(frames[:, everything], reference[:, everything])
    motions = {}
    for i, name in enumerate(names):
        mine = owner[nearest] == i
        motions[name] = {
            "share_of_frames": float(mine.mean()),
            "normalized_return": float(rewards[mine].mean()) if mine.any() else None,
        }
    out["motions"] = motions
    out["joint_distance_deg"]["all"] = float(np.degrees(_nearest_distance(frames, reference).mean()))
    out["coverage_deg"]["all"] = float(np.degrees(_nearest_distance(reference, frames).mean()))
    return out


def _pairwise(frames: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """RMS joint distance between every frame and every reference frame."""
    squared = (frames**2).sum(1)[:, None] + (reference**2).sum(1)[None, :] - 2.0 * frames @ reference.T
    return np.sqrt(np.maximum(squared, 0.0) / frames.shape[1])


def _nearest_distance(frames: np.ndarray, reference: np.ndarray, chunk: int = 2048) -> np.ndarray:
    return np.concatenate([_pairwise(frames[i : i + chunk], reference).min(1) for i in range(0, len(frames), chunk)])


def _nearest_index(frames: np.ndarray, reference: np.ndarray, chunk: int = 2048) -> np.ndarray:
    return np.concatenate([_pairwise(frames[i : i + chunk], reference).argmin(1) for i in range(0, len(frames), chunk)])


TaskController = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def evaluate_task(
    envs,
    controller: TaskController,
    episodes: int = 100,
    seed: int = 0,
    max_steps: int = 300,
    task_reward: str | None = None,
) -> dict:
    """A task policy over the first `episodes` episodes to end in `envs` (a
    vector environment of a task, reset with `seed`: every episode draws its
    own start and target). `controller(observations, interaction, started)`
    gives the actions (`started` marks environments whose episode just
    began). Figures: `success_rate` (the environment's `info["success"]` at
    the episode's end), `normalized_return` (the task reward summed over the
    episode over `max_steps`, so in [0, 1], a fall counting what it missed),
    `fall_rate`, `mean_episode_steps`, and per episode its success, return
    and, where the environment gives `info["goal"]`, its start and target,
    in the order the episodes ended (`episodes_detail`). With `task_reward`,
    the task's reward is that `info` key (a transfer environment's, whose
    own reward is tracking), and the environment's reward is reported as
    `normalized_tracking_return` (per episode `tracking_return`)."""
    n = envs.num_envs
    observations, info = envs.reset(seed=seed)
    interaction = np.asarray(info["interaction"], dtype=np.float32).reshape(n, -1)
    goals = [_goal(info, i) for i in range(n)]
    started = np.ones(n, bool)
    running = np.zeros(n)
    tracking = np.zeros(n)
    steps = np.zeros(n, dtype=np.int64)
    detail = []
    falls = 0
    while len(detail) < episodes:
        action = controller(observations, interaction, started)
        observations, reward, terminated, truncated, info = envs.step(action)
        interaction = np.asarray(info["interaction"], dtype=np.float32).reshape(n, -1)
        done = terminated | truncated
        if task_reward is None:
            running += reward
        else:
            tracking += reward
            running += _info_values(info, task_reward, done)
        steps += 1
        success = np.asarray(info.get("final_info", {}).get("success", np.zeros(n, bool)))
        for i in np.flatnonzero(done):
            if len(detail) < episodes:
                falls += int(terminated[i])
                episode = {"success": bool(success[i]), "return": float(running[i] / max_steps), "steps": int(steps[i])}
                if task_reward is not None:
                    episode["tracking_return"] = float(tracking[i] / max_steps)
                detail.append(episode | ({"goal": goals[i]} if goals[i] else {}))
            goals[i] = _goal(info, i)  # the next episode's, drawn at the same-step reset
        running[done], tracking[done], steps[done] = 0.0, 0.0, 0
        started = done
    figures = {}
    if task_reward is not None:
        figures["normalized_tracking_return"] = float(np.mean([d["tracking_return"] for d in detail]))
    return figures | {
        "episodes": len(detail),
        "success_rate": float(np.mean([d["success"] for d in detail])),
        "normalized_return": float(np.mean([d["return"] for d in detail])),
        "fall_rate": falls / len(detail),
        "mean_episode_steps": float(np.mean([d["steps"] for d in detail])),
        "episodes_detail": detail,
    }


def _info_values(info: dict, key: str, done: np.ndarray) -> np.ndarray:
    """`info[key]` of every environment, the ended episodes' from their final info."""
    values = np.asarray(info[key], dtype=float).copy() if key in info else np.zeros(len(done))
    if done.any():
        values[done] = np.asarray(info["final_info"][key], dtype=float)[done]
    return values


def _goal(info: dict, index: int) -> dict:
    """Environment `index`'s `info["goal"]` as plain numbers ({} without one)."""
    goal = info.get("goal")
    if not isinstance(goal, dict):
        return {}
    return {k: np.asarray(v[index]).tolist() for k, v in goal.items() if not k.startswith("_")}


def behavior_report(agent, envs, standing: np.ndarray, episodes: int, seed: int) -> dict:
    """A behavior run's evaluation: `evaluate` of the agent's deterministic
    policy and of the robot standing (`standing`, its action) on the same
    seeded episodes, and how much closer to the references the policy is
    (per part, degrees; positive: closer than standing)."""
    demos = agent.demos
    columns = np.asarray(demos.meta["joint_columns"])

    def style(amp: dict) -> np.ndarray:
        return agent.combine(agent.group_style_rewards(agent.group_windows(amp)))

    latent = agent.config.latent
    common = {"episodes": episodes, "seed": seed}
    learned = evaluate(
        envs,
        lambda obs, z: agent.act(obs, z, deterministic=True)[0],
        demos,
        columns,
        style,
        latent_groups=list(agent.model.policy.config.latent_sizes),
        latent_size=latent.size,
        resample=(latent.resample_min, latent.resample_max),
        **common,
    )
    baseline = evaluate(envs, standing_policy(standing), demos, columns, style, **common)
    return {
        "evaluation": {"policy": learned, "standing": baseline, "episodes": episodes, "seed": seed},
        "closer_than_standing_deg": {
            part: round(baseline["joint_distance_deg"][part] - learned["joint_distance_deg"][part], 2)
            for part in learned["joint_distance_deg"]
        },
        "better_coverage_than_standing_deg": {
            part: round(baseline["coverage_deg"][part] - learned["coverage_deg"][part], 2)
            for part in learned["coverage_deg"]
        },
    }


def behavior_summary(report: dict) -> dict:
    """A behavior report's headline figures, next to standing's (and the
    teacher's, for a clone; a clone of several motions, each motion's)."""
    # (coverage: newer reports; objects held: environments with the clips' objects)
    keys = ("fall_rate", "mean_episode_seconds", "travel_ratio", "coverage_deg", "objects_held")
    if "by_motion" in report["evaluation"]:
        return {
            f"{motion}_{who}_{k}": evaluation[who][k]
            for motion, evaluation in report["evaluation"]["by_motion"].items()
            for who in ("policy", "teacher", "standing")
            for k in keys
            if k in evaluation[who]
        }
    policy, standing = report["evaluation"]["policy"], report["evaluation"]["standing"]
    if "teacher" in report["evaluation"]:
        evaluation = report["evaluation"]
        return {
            f"{who}_{k}": evaluation[who][k]
            for who in ("policy", "teacher", "standing")
            for k in keys
            if k in evaluation[who]
        }
    return {
        "fall_rate": policy["fall_rate"],
        "normalized_return": round(policy["normalized_return"], 3),
        "standing_normalized_return": round(standing["normalized_return"], 3),
        "joint_distance_deg": round(policy["joint_distance_deg"]["all"], 2),
        "standing_joint_distance_deg": round(standing["joint_distance_deg"]["all"], 2),
        "coverage_deg": round(policy["coverage_deg"]["all"], 2),
        "standing_coverage_deg": round(standing["coverage_deg"]["all"], 2),
    }


def task_report(
    envs, controller: TaskController, standing: np.ndarray, episodes: int, seed: int, task_reward: str | None = None
) -> tuple[dict, dict]:
    """A skill run's evaluation: `evaluate_task` of its controller and of the
    robot standing on the same seeded task instances; the evaluation (with
    its best episode) and that best episode's details."""
    result = evaluate_task(envs, controller, episodes, seed, task_reward=task_reward)
    standing_result = evaluate_task(envs, standing_policy(standing), episodes, seed, task_reward=task_reward)
    standing_result.pop("episodes_detail")
    detail = result.pop("episodes_detail")
    best = max(range(len(detail)), key=lambda i: (detail[i]["success"], detail[i]["return"]))
    return {**result, "seed": seed, "best_episode": detail[best], "standing": standing_result}, detail[best]


def task_summary(report: dict) -> dict:
    """A skill report's headline figures, next to standing's."""
    e = report["evaluation"]
    return {
        "success_rate": e["success_rate"],
        "normalized_return": round(e["normalized_return"], 3),
        "fall_rate": e["fall_rate"],
        "mean_episode_steps": round(e["mean_episode_steps"], 1),
        "standing_success_rate": e["standing"]["success_rate"],
        "standing_normalized_return": round(e["standing"]["normalized_return"], 3),
    }


InfoPolicy = Callable[[np.ndarray, dict], np.ndarray]
MIN_REFERENCE_TRAVEL = 0.05  # m: an episode whose clip moves less has no travel ratio (a wave's would be noise)


def travel_ratio(travels: list[float], references: list[float]) -> float | None:
    """The mean over episodes of the robot's travel over its clip's (each
    episode's own), those whose clip moves under `MIN_REFERENCE_TRAVEL`
    left out; None if that leaves none."""
    ratios = [t / r for t, r in zip(travels, references) if r > MIN_REFERENCE_TRAVEL]
    return float(np.mean(ratios)) if ratios else None


def teacher_policy(observations: np.ndarray, info: dict) -> np.ndarray:
    """The whole-body controller's actions (`info["teacher_action"]`), as an `InfoPolicy`."""
    return np.asarray(info["teacher_action"], dtype=np.float32)


def follow_clips(
    envs,
    policy: InfoPolicy,
    episodes: int = 20,
    seed: int = 0,
    coverage_of: tuple[np.ndarray, np.ndarray] | None = None,
) -> dict:
    """How `policy` (observations and the step's info to actions) performs
    the clips over the first `episodes` episodes to end in `envs` (made
    with `teacher=True`, so that each step's info has where the clip's
    root is): the fall rate, the mean episode length (s, from
    `info["time"]`), and the pelvis' horizontal travel over each episode
    against the reference's over the same time (`travel_ratio`). With
    `coverage_of` (the observation's joint-position columns and the
    reference's joint frames), also `coverage_deg`: the mean over the
    reference's frames of the distance to the nearest frame of the
    episodes (`evaluate`'s coverage, over all joints). In environments
    with the clips' objects (`info["object_rise"]`), also how many
    episodes had an object (`object_episodes`) and how many of those
    lifted it at least `HELD_LIFT` above where it started at some step
    (`objects_held`): nothing but the robot lifts an object off its table."""
    observations, info = envs.reset(seed=seed)
    start = {key: np.array(info[key]) for key in ("root_xy", "reference_root_xy")}
    falls, seconds, travel, reference = 0, [], [], []
    columns = None if coverage_of is None else np.asarray(coverage_of[0])
    running: list[list[np.ndarray]] = [[] for _ in range(envs.num_envs)]
    frames: list[np.ndarray] = []
    rise = np.full(envs.num_envs, np.nan)  # each environment's highest object rise in its episode so far
    object_episodes = held = 0
    while len(seconds) < episodes:
        observations, _, terminated, truncated, info = envs.step(policy(observations, info))
        done = terminated | truncated
        if "object_rise" in info:
            now = np.asarray(info["object_rise"], dtype=float).copy()
            for i in np.flatnonzero(done):
                now[i] = info["final_info"]["object_rise"][i]
            rise = np.fmax(rise, now)
        if columns is not None:
            after = observations.copy()
            for i in np.flatnonzero(done):  # the ended episode's last state
                after[i] = info["final_obs"][i]
            for i in range(envs.num_envs):
                running[i].append(after[i, columns])
        for i in np.flatnonzero(done):
            last = info["final_info"]
            if len(seconds) < episodes:
                falls += int(terminated[i])
                seconds.append(float(last["time"][i]))
                travel.append(float(np.linalg.norm(last["root_xy"][i] - start["root_xy"][i])))
                reference.append(float(np.linalg.norm(last["reference_root_xy"][i] - start["reference_root_xy"][i])))
                frames.extend(running[i])
                object_episodes += int(np.isfinite(rise[i]))
                held += int(rise[i] >= HELD_LIFT)
            running[i] = []
            rise[i] = np.nan
            for key in start:
                start[key][i] = info[key][i]
    report = {
        "episodes": len(seconds),
        "fall_rate": falls / len(seconds),
        "mean_episode_seconds": float(np.mean(seconds)),
        "root_travel_m": float(np.mean(travel)),
        "reference_travel_m": float(np.mean(reference)),
        "travel_ratio": travel_ratio(travel, reference),
    }
    if object_episodes:
        report |= {"object_episodes": object_episodes, "objects_held": held}
    if coverage_of is not None:
        report["coverage_deg"] = float(
            np.degrees(_nearest_distance(np.asarray(coverage_of[1]), np.array(frames)).mean())
        )
    return report


def clone_report(agent, envs, standing: np.ndarray, episodes: int, seed: int, motions: list[str] | None = None) -> dict:
    """A teacher-labelled run's evaluation: `follow_clips` of the policy's
    mean, of the teacher itself and of the robot standing, on the same
    seeded episodes (each clip from its start, or from the standing pose),
    with the coverage of the frames of `motions` (default: all of the agent's demonstrations)."""
    stand = standing_policy(standing)
    runs = {
        "policy": lambda obs, info: agent.act(obs, deterministic=True)[0],
        "teacher": teacher_policy,
        "standing": lambda obs, info: stand(obs),
    }
    demos = agent.demos
    reference = np.concatenate([demos.motions[m].joints for m in (motions or list(demos.motions))])
    coverage_of = (np.asarray(demos.meta["joint_columns"]), reference)
    evaluation = {name: follow_clips(envs, act, episodes, seed, coverage_of) for name, act in runs.items()}
    return {"evaluation": evaluation | {"episodes": episodes, "seed": seed}}
