"""Pool several runs of ``scripts/train_residual.py`` on the same held-out instances (a replication summary).

For each held-out instance i, d_i is the mean over the runs of (final policy's success − zero residual's
success) on that run's episode of i; the pooled figure is the mean over tasks (strata weighted equally) of the
task's mean d_i, with a 95 % stratified percentile bootstrap over the **instances** (a run's pairs of an instance
are resampled together: a new reset seed on the same recording is close to a replay). With one run this is that
run's own statistic. This is how docs/design.md §6 declared the seventh run's secondary figure; it is never a
run's criterion. Example::

    python scripts/pool_residual_runs.py /tmp/rl6/run/results.json /tmp/rl7/run/results.json

Prints one line per run and the pooled line; ``--json FILE`` also writes them. Exit 2 with a one-line message
when a file is missing or unreadable, lacks a field, or the runs do not cover the same instances and tasks.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.evaluation.compare import paired_difference


class PoolError(ValueError):
    """A results file that cannot be pooled; the message names the file and what was expected."""


def instance_differences(path: Path) -> dict[str, tuple[str, float]]:
    """{instance: (task, final − zero success)} of one run's ``results.json`` (its ``residual`` arm is the final
    policy: the chosen checkpoint, or the start where the run's rule kept it)."""
    try:
        episodes = json.loads(path.read_text())["episodes"]
        zero = {e["instance"]: e for e in episodes["zero_residual"]}
        final = {e["instance"]: e for e in episodes["residual"]}
    except (OSError, ValueError) as err:
        raise PoolError(f"{path}: expected a train_residual.py results.json ({err})") from err
    except (KeyError, TypeError) as err:
        raise PoolError(f"{path}: expected episodes.residual and episodes.zero_residual rows with "
                        f"'instance', 'task' and 'success' (missing {err})") from err
    if sorted(zero) != sorted(final):
        raise PoolError(f"{path}: expected the residual and zero-residual arms on the same instances")
    out = {}
    for name, e in final.items():
        if e["task"] != zero[name]["task"]:
            raise PoolError(f"{path}: instance {name!r} has task {e['task']!r} in one arm and "
                            f"{zero[name]['task']!r} in the other")
        out[name] = (str(e["task"]), float(e["success"]) - float(zero[name]["success"]))
    return out


def pool(runs: list[dict[str, tuple[str, float]]], names: list[str], *, seed: int = 0
         ) -> tuple[float, float, float]:
    """(mean, low, high): the runs' per-instance differences averaged, stratified by task, bootstrapped over
    instances (:func:`~socialaff_sim.evaluation.compare.paired_difference`, 10,000 resamples, generator ``seed``)."""
    first = runs[0]
    for name, run in zip(names[1:], runs[1:]):
        if sorted(run) != sorted(first) or any(run[i][0] != first[i][0] for i in first):
            raise PoolError(f"{name}: expected the same held-out instances and tasks as {names[0]}")
    strata: dict[str, list[float]] = {}
    for i in sorted(first):
        strata.setdefault(first[i][0], []).append(float(np.mean([run[i][1] for run in runs])))
    groups = [np.asarray(strata[task]) for task in sorted(strata)]
    return paired_difference(groups, rng=np.random.default_rng(seed))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("results", nargs="+", type=Path, help="results.json of each run")
    parser.add_argument("--seed", type=int, default=0, help="the bootstrap's generator seed")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args(argv)
    try:
        runs = [instance_differences(p) for p in args.results]
        names = [str(p) for p in args.results]
        rows = [(name, *pool([run], [name], seed=args.seed)) for name, run in zip(names, runs)]
        rows.append(("pooled", *pool(runs, names, seed=args.seed)))
    except PoolError as err:
        print(f"pool_residual_runs: {err}", file=sys.stderr)
        return 2
    for name, mean, low, high in rows:
        print(f"{name}: final − zero success {mean:+.4f} [{low:+.4f}, {high:+.4f}]")
    if args.json:
        atomic_write_text(args.json, json.dumps(
            [{"run": n, "mean": m, "ci95": [lo, hi]} for n, m, lo, hi in rows], indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
