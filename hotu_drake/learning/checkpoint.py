"""The checkpoint format: what training writes, `PolicySystem` loads and
`--resume` continues from.

A `torch.save` dictionary (read back with `weights_only=True`):

| key | meaning |
|---|---|
| format_version | 2 (version 1, the untrained policies of hotu_drake 0.2, is refused) |
| kind | `training` (everything to resume) or `policy` (what a scenario needs) |
| embodiment, hands | which model the policy drives |
| policy | `config` (`PolicyConfig` fields) and `state_dict` (weights, observation normaliser, action offset) |
| latent | `size`, `resample_min`, `resample_max`: the prior a deployed policy draws its latents from |
| control_rate | Hz, the rate the policy was trained at |
| meta | algorithm, motions, part groups, seed, samples, the training configuration |
| state | (`training` only) `Agent.state_dict()`: critic, discriminators, encoders, optimisers, replay, RNG, counters |
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import torch

from hotu_drake.errors import InputError
from hotu_drake.io import atomic_output
from hotu_drake.learning.networks import PolicyConfig, PolicyNetwork

FORMAT_VERSION = 2
KINDS = ("training", "policy")


class CheckpointError(InputError):
    """A file that is not a checkpoint this version understands."""


def save_checkpoint(
    path: str | Path,
    network: PolicyNetwork,
    embodiment: str,
    hands: str,
    meta: dict | None = None,
    *,
    latent: dict | None = None,
    control_rate: float = 30.0,
    state: dict | None = None,
) -> Path:
    """Write a checkpoint atomically: `kind` training when `state` is given, else policy."""
    path = Path(path)
    size = max(network.config.latent_sizes.values(), default=0)
    data = {
        "format_version": FORMAT_VERSION,
        "kind": "training" if state is not None else "policy",
        "embodiment": embodiment,
        "hands": hands,
        "policy": {"config": dataclasses.asdict(network.config), "state_dict": network.state_dict()},
        "latent": latent or {"size": size, "resample_min": 1, "resample_max": 150},
        "control_rate": float(control_rate),
        "meta": meta or {},
    }
    if state is not None:
        data["state"] = state
    with atomic_output(path) as tmp:
        torch.save(data, tmp)
    return path


def read_checkpoint(path: str | Path, kind: str | None = None) -> dict:
    """The checkpoint's dictionary, checked for its version (and `kind` if given)."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError("no such checkpoint file", path)
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises many kinds for a bad file
        raise CheckpointError(f"not a readable checkpoint ({type(error).__name__})", path) from None
    if not isinstance(data, dict) or "format_version" not in data:
        raise CheckpointError("not a hotu_drake checkpoint", path)
    version = data["format_version"]
    if version != FORMAT_VERSION:
        raise CheckpointError(
            f"a checkpoint of format version {version}; this hotu_drake reads version {FORMAT_VERSION} "
            "(train again, or use the hotu_drake version that wrote it)",
            path,
        )
    if data.get("kind") not in KINDS:
        raise CheckpointError(f"unknown checkpoint kind {data.get('kind')!r}", path)
    if kind is not None and data["kind"] != kind:
        raise CheckpointError(f"a {data['kind']} checkpoint, not a {kind} one (it cannot resume training)", path)
    return data


def load_checkpoint(path: str | Path) -> tuple[PolicyNetwork, dict]:
    """The policy network (in eval mode) and the checkpoint's other entries (no weights)."""
    data = read_checkpoint(path)
    try:
        config = dict(data["policy"]["config"])
        config["hidden"] = tuple(config["hidden"])
        config["action_offset"] = tuple(config["action_offset"])
        config["latent_sizes"] = dict(config["latent_sizes"])
        network = PolicyNetwork(PolicyConfig(**config))
        network.load_state_dict(data["policy"]["state_dict"])
    except (KeyError, TypeError, ValueError, RuntimeError) as error:  # missing or mistyped fields, wrong weights
        reason = str(error).strip().splitlines()[0][:100] if str(error).strip() else type(error).__name__
        raise CheckpointError(f"a damaged or incompatible checkpoint ({reason})", path) from None
    network.eval()
    return network, {k: v for k, v in data.items() if k not in ("policy", "state")}
