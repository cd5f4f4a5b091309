"""The checkpoint format that training writes and `PolicySystem` loads.

A `torch.save` dictionary:

| key | meaning |
|---|---|
| format_version | 1 |
| embodiment, hands | which model the policy drives |
| config | `PolicyConfig` fields (observation and action sizes, part latents, hidden layers) |
| state_dict | network weights, observation normaliser included |
| training | free-form training configuration (for the record) |
"""

import dataclasses
from pathlib import Path

import torch

from hotu_drake.errors import InputError
from hotu_drake.io import atomic_output
from hotu_drake.learning.policy import PolicyConfig, PolicyNetwork

FORMAT_VERSION = 1


class CheckpointError(InputError):
    """A file that is not a policy checkpoint this version understands."""


def save_checkpoint(
    path: str | Path, network: PolicyNetwork, embodiment: str, hands: str, training: dict | None = None
) -> Path:
    """Write a checkpoint atomically."""
    path = Path(path)
    data = {
        "format_version": FORMAT_VERSION,
        "embodiment": embodiment,
        "hands": hands,
        "config": dataclasses.asdict(network.config),
        "state_dict": network.state_dict(),
        "training": training or {},
    }
    with atomic_output(path) as tmp:
        torch.save(data, tmp)
    return path


def load_checkpoint(path: str | Path) -> tuple[PolicyNetwork, dict]:
    """The network (in eval mode) and the checkpoint's metadata."""
    path = Path(path)
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # torch raises many kinds for a bad file
        raise CheckpointError(f"{path}: not a readable checkpoint ({type(error).__name__})") from None
    if not isinstance(data, dict) or data.get("format_version") != FORMAT_VERSION:
        raise CheckpointError(f"{path}: not a hotu_drake policy checkpoint of format version {FORMAT_VERSION}")
    try:
        config = dict(data["config"])
        config = PolicyConfig(**{**config, "hidden": tuple(config["hidden"])})
        network = PolicyNetwork(config)
        network.load_state_dict(data["state_dict"])
    except (KeyError, TypeError, ValueError, RuntimeError) as error:  # missing or mistyped fields, wrong weights
        reason = str(error).strip().splitlines()[0][:100] if str(error).strip() else type(error).__name__
        raise CheckpointError(f"{path}: a damaged or incompatible checkpoint ({reason})") from None
    network.eval()
    return network, {k: v for k, v in data.items() if k != "state_dict"}
