"""`python -m hotu_drake.train reach RUN`: how far a behavior run's latents
move its robot (`envs.reach.latent_reach`), printed as JSON."""

from __future__ import annotations

import json

from hotu_drake.commands.run_options import load_controller
from hotu_drake.envs.reach import latent_reach
from hotu_drake.errors import InputError, check_number


def add_parser(sub) -> None:
    reach = sub.add_parser(
        "reach", help="how far a behavior run's latents move its hands and pelvis from standing (JSON)"
    )
    reach.add_argument("run", help="a behavior run folder (train pretrain, with latents: dail or ase)")
    reach.add_argument("--latents", type=int, default=12, help="latents drawn from the prior (default 12)")
    reach.add_argument("--seconds", type=float, default=2.0, help="how long each is held from standing (default 2)")
    reach.add_argument("--seed", type=int, default=0, help="the latents' and the drops' seed")


def reach_command(args) -> int:
    check_number(args.latents, "--latents", low=1, high=1000, integer=True)
    check_number(args.seconds, "--seconds", low=0.1, high=60.0, unit="s")
    check_number(args.seed, "--seed", low=0, high=2**31 - 1, integer=True)
    llc = load_controller(args.run, "run")
    if not llc.latent_groups:
        raise InputError(f"{args.run}: a controller without latents ({llc.config.algo}); nothing to reach with")
    print(json.dumps(latent_reach(llc, args.latents, args.seconds, args.seed), indent=2))
    return 0
