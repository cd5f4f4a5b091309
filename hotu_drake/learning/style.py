"""Style rewards and the losses of the discriminators and encoders.

Discriminator objective (eq. 1 of the method, the GAN form): binary cross
entropy with demonstration windows labelled real and policy windows fake,
`-E_demo[log sigmoid(l)] - E_policy[log(1 - sigmoid(l))]` of the logit l,
plus a gradient penalty on demonstration inputs, an L2 penalty on the
logit layer's weights and weight decay on the hidden layers.

Style reward of a part group, the method's form r = max(0, 1 - 0.25 (D - 1)^2)
with D = 2 sigmoid(l) - 1. That D is the BCE discriminator's probability of
"real" mapped from [0, 1] onto [-1, 1], where the formula was written for a
discriminator whose targets are +1 for real and -1 for fake (AMP's least
squares form): the reward is then 1 - (1 - sigmoid(l))^2, rising
monotonically from 0 (surely fake) to 1 (surely real). The raw logit
would make it fall again for logits above 1 (samples that look "too real"
would be punished), and the probability itself would confine it to
[0.75, 1]. The `log` form, -log(1 - sigmoid(l)) as in ASE, is unbounded;
it is bounded as r / (1 + r) before it is combined.

Combination over groups: `product` (DAIL: every part must look right for
the reward to be high; bounded factors, so adding groups does not
collapse it below what the weakest group allows), `mean` (PMP, see
`combine_rewards`), `single` (one whole-body group: AMP, ASE).
"""

from __future__ import annotations

import torch
from torch.nn import functional as F

from hotu_drake.learning.networks import StyleNetwork


def style_reward(logit: torch.Tensor, form: str = "amp") -> torch.Tensor:
    """A group's bounded style reward in [0, 1] from its discriminator's logit."""
    probability = torch.sigmoid(logit)
    if form == "amp":
        d = 2.0 * probability - 1.0
        return (1.0 - 0.25 * (d - 1.0) ** 2).clamp_min(0.0)
    if form == "log":
        r = -torch.log((1.0 - probability).clamp_min(1e-4))
        return r / (1.0 + r)
    raise ValueError(f"unknown style reward form {form!r}")


def combine_rewards(rewards: torch.Tensor, how: str) -> torch.Tensor:
    """Per-group rewards (G, ...) combined into one (...).

    - `product`: prod_g r_g (DAIL).
    - `mean`: (1 / G) sum_g r_g, PMP's combination: Bae et al., "PMP:
      Learning to Physically Interact with Environments using Part-wise
      Motion Priors" (SIGGRAPH 2023) sum the part discriminators' rewards
      with weights; equal weights summing to one here, so that the result
      stays in [0, 1]. (PMP's whole-body code is not public; this follows
      the paper's text.)
    - `single`: the one group's reward (AMP and ASE have one discriminator).
    """
    if how == "product":
        return rewards.prod(dim=0)
    if how == "mean":
        return rewards.mean(dim=0)
    if how == "single":
        if rewards.shape[0] != 1:
            raise ValueError(f"'single' needs one group, got {rewards.shape[0]}")
        return rewards[0]
    raise ValueError(f"unknown combination {how!r}")


def encoder_reward(estimate: torch.Tensor, latent: torch.Tensor, form: str = "shifted") -> torch.Tensor:
    """How well the encoder recovers the latent: `clipped` max(0, <z_hat, z>)
    (ASE) or `shifted` (1 + <z_hat, z>) / 2, both in [0, 1]; the shifted
    form keeps a gradient where the estimate points away."""
    cosine = (estimate * latent).sum(-1)
    if form == "clipped":
        return cosine.clamp_min(0.0)
    if form == "shifted":
        return 0.5 * (1.0 + cosine)
    raise ValueError(f"unknown encoder reward form {form!r}")


def discriminator_loss(
    network: StyleNetwork,
    demo: torch.Tensor,
    policy: torch.Tensor,
    grad_penalty: float,
    logit_regularization: float,
    weight_decay: float,
) -> tuple[torch.Tensor, dict[str, float]]:
    """Eq. (1) with its regularisers, on flat normalised inputs; and the
    statistics to log (accuracy on each side, mean logits)."""
    demo = demo.detach().requires_grad_(grad_penalty > 0)
    demo_logit, policy_logit = network.logit(demo), network.logit(policy)
    bce = F.binary_cross_entropy_with_logits(
        demo_logit, torch.ones_like(demo_logit)
    ) + F.binary_cross_entropy_with_logits(policy_logit, torch.zeros_like(policy_logit))
    loss = bce
    penalty = torch.zeros(())
    if grad_penalty > 0:
        (gradient,) = torch.autograd.grad(demo_logit.sum(), demo, create_graph=True)
        penalty = gradient.square().sum(-1).mean()
        loss = loss + grad_penalty * penalty
    loss = loss + logit_regularization * network.logit_weights().square().sum()
    loss = loss + weight_decay * sum(w.square().sum() for w in network.trunk_weights())
    stats = {
        "loss": float(bce.detach()),
        "grad_penalty": float(penalty.detach()),
        "accuracy_demo": float((demo_logit > 0).float().mean()),
        "accuracy_policy": float((policy_logit < 0).float().mean()),
        "logit_demo": float(demo_logit.detach().mean()),
        "logit_policy": float(policy_logit.detach().mean()),
    }
    return loss, stats


def encoder_loss(network: StyleNetwork, inputs: torch.Tensor, latent: torch.Tensor) -> torch.Tensor:
    """-E <q(inputs), z>: the encoder learns which latent made a window."""
    return -(network.encode(inputs) * latent).sum(-1).mean()


def diversity_loss(mean: torch.Tensor, other_mean: torch.Tensor, latents: dict, other_latents: dict) -> torch.Tensor:
    """ASE's diversity objective: different latents should give actions
    that differ in proportion to how far apart the latents are,
    (1 - E ||mu(s, z) - mu(s, z')||^2 / (0.5 - 0.5 <z, z'> + 1e-5))^2, with the
    latent distance averaged over the groups."""
    action_distance = (mean - other_mean).square().mean(-1)
    latent_distance = torch.stack([0.5 - 0.5 * (latents[g] * other_latents[g]).sum(-1) for g in latents]).mean(0)
    return (1.0 - action_distance / (latent_distance + 1e-5)).square().mean()
