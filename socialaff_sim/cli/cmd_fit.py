"""``socialaff-sim fit``: learn the affordance model of one interaction (Algorithm 1)."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np

from .validate import MAX_SUBEVENTS, add_data_options, declare_outputs, int_range, non_negative_int
from .help_format import HelpFormatter

__all__ = ["register", "run"]


def run(args: argparse.Namespace) -> int:
    """Load the data, fit, save, print a summary."""
    from ..data import load_dataset  # noqa: PLC0415
    from ..inference.presets import preset  # noqa: PLC0415
    from ..learning.estimator import SocialAffordanceModel  # noqa: PLC0415
    from ..learning.history import summary_line  # noqa: PLC0415

    data = load_dataset(args.data, policy=args.policy, units=args.units).of_label(args.interaction)
    chosen = preset(args.preset)
    learning = chosen.learning
    if args.iterations is not None:
        learning = dataclasses.replace(learning, iterations=args.iterations)
    config = chosen.affordance
    if args.subevents is not None:
        config = dataclasses.replace(config, n_subevents=args.subevents)
    model = SocialAffordanceModel(config, learning)
    if not args.quiet:
        print(f"fitting {args.interaction!r} on {len(data)} instances: atomic intervals and the initial parse, "
              f"then {learning.iterations} MCMC iterations", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    model.fit(list(data), rng=np.random.default_rng(args.seed), progress=not (args.no_progress or args.quiet))
    seconds = time.perf_counter() - t0
    path = model.save(args.out)
    print(f"fitted {model.label_!r} on {len(data)} instances in {seconds:.1f} s with the {args.preset} preset "
          f"({learning.iterations} iterations, acceptance {model.acceptance_rate_:.3f}, "
          f"log P* {model.log_posterior_:.1f})")
    print(summary_line(model.history_))
    durations = model.mean_durations_
    for s, name in enumerate(model.subevent_names_):
        print(f"  {s}: {name:12s} mean duration {durations[s]:.2f} s")
    print(f"wrote {path}; next: socialaff-sim show {path}, then synthesize or simulate with --model {path}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``fit`` sub-command."""
    p = subparsers.add_parser(
        "fit",
        help="learn the social affordance model of one interaction",
        description="Learn sub-events, joint groupings and potentials of one interaction from every instance "
        "of it in the data (Algorithm 1: an initial parse, then --iterations sweeps of MCMC over parses, 0 with the "
        "default preset and 100 with the paper's); shows one progress step per iteration. About 20 s of CPU "
        "for 18 synthetic instances with the default preset.",
        epilog="example:\n  socialaff-sim fit --data synthetic --interaction shake_hands --out model.npz\n"
        "  socialaff-sim fit --data synthetic --interaction shake_hands --out paper.npz --preset paper\n"
        "  socialaff-sim fit --data npz:my_recordings --interaction hand_over --out hand_over.npz",
        formatter_class=HelpFormatter,
    )
    p.add_argument("--data", required=True, metavar="SPEC",
                   help="dataset spec: sbu:PATH, handover:PATH, nuisi:PATH, hhoi:PATH, npz:DIR or synthetic[:SEED]")
    p.add_argument("--interaction", required=True, metavar="NAME", help="interaction label to learn (e.g. shake_hands)")
    p.add_argument("--out", required=True, metavar="MODEL.npz", help="where to write the model")
    p.add_argument("--iterations", type=non_negative_int, default=None,
                   help="outer MCMC iterations after the initial parse (default: the preset's, 0 default, 100 paper)")
    p.add_argument("--subevents", type=int_range(1, MAX_SUBEVENTS), default=None, metavar="S",
                   help=f"|S|, sub-event types, 1 to {MAX_SUBEVENTS} (default: per interaction)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed (default 0)")
    p.add_argument("--preset", choices=("default", "paper"), default="default",
                   help="model and learner settings: this project's (default) or the paper's, as this project "
                   "reads it (paper); docs/design.md lists the differences")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_data_options(p)
    declare_outputs(p, out="file")
    p.set_defaults(func=run)
