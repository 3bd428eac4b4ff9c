"""The inner CV's partition draws on the development split (issue 24; docs/design.md §8, "Repeated inner folds"),
for scripts/dev_switching.py: its regression arguments (``--inner-folds``, ``--penalties``) and ``--draws K``, which
fits the ``default`` variant's switching regression once per partition draw k = 0 … K−1 (the k-th partition the
generator seeded ``--seed`` gives; k = 0 is ``sw:default`` itself) on the same traces. Per validation instance it
records ``sw:default@k`` and ``sw:default@mean`` (the mean over the K draws: the default's error averaged over its own
partition draw). The library never imports this module.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence

import numpy as np

from socialaff_sim.data import Interaction
from socialaff_sim.inference.reaction_regression import inner_folds, stack_instances
from socialaff_sim.inference.switching import SwitchingConfig, SwitchingRegression, Trace, instance_rows


def add_regression_arguments(ap: argparse.ArgumentParser) -> None:
    """The switching regression's settings that apply to every variant (the traces and their cache unchanged)."""
    d = SwitchingConfig()
    ap.add_argument("--inner-folds", type=int, default=d.inner_folds,
                    help="folds of every variant's inner CV (SwitchingConfig.inner_folds, default %(default)s)")
    ap.add_argument("--penalties", default="", help="comma-separated ridge penalties of every variant "
                    "(SwitchingConfig.penalties; default: the library's)")
    ap.add_argument("--draws", type=int, default=1,
                    help="K > 1: also the default variant per partition draw k < K (_dev_draws.py)")


def regression_settings(args: argparse.Namespace) -> dict[str, object]:
    """The SwitchingConfig fields of :func:`add_regression_arguments`; SystemExit (exit 2) on a bad value."""
    if args.inner_folds < 2 or args.draws < 1:
        raise SystemExit(f"--inner-folds / --draws: expected >= 2 / >= 1, found {args.inner_folds} / {args.draws}")
    out: dict[str, object] = {"inner_folds": args.inner_folds}
    if args.penalties:
        try:
            out["penalties"] = tuple(float(x) for x in args.penalties.split(","))
        except ValueError:
            raise SystemExit(f"--penalties: expected comma-separated numbers, found {args.penalties!r}") from None
    return out


def partition_draws(
    config: SwitchingConfig, train: Sequence[Interaction], traces: Sequence[Trace], n_subevents: int, seed: int, draws: int,
    first: list[float], score: Callable[[SwitchingRegression], list[float]],
) -> tuple[dict[str, list[float]], str]:
    """The per-instance errors (``score``'s, m) of ``config``'s regression fitted once per partition draw k = 1 …
    K−1 (draw 0 is the caller's own fit, whose errors are ``first``: ``sw:default@0``) and their per-instance mean
    over k = 0 … K−1 (``sw:default@mean``); and the seconds each fit took, as text."""
    usable = np.unique(stack_instances(
        train, config.n_observed,
        lambda i, inst: instance_rows(inst, traces[i], config.n_observed, config.features, stride=config.row_stride),
        "partition draws")[2])
    per: dict[str, list[float]] = {}
    times: dict[str, str] = {}
    for k in range(1, draws):
        rng = np.random.default_rng(seed)
        for _ in range(k):  # the partitions drawn before the k-th (as SwitchingRegression.fit draws them)
            inner_folds(train, usable, config.inner_folds, rng, contiguous=config.contiguous)
        t = time.perf_counter()
        per[f"sw:default@{k}"] = score(SwitchingRegression(config).fit(train, traces, n_subevents=n_subevents, rng=rng))
        times[f"@{k}"] = f"{time.perf_counter() - t:.1f}s"
    per["sw:default@0"] = [float(e) for e in first]
    per["sw:default@mean"] = [float(e) for e in np.mean([per[f"sw:default@{k}"] for k in range(draws)], axis=0)]
    return per, ", ".join(f"{k} {v}" for k, v in times.items())
