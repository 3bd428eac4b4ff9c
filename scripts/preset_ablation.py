"""Measured effect of each difference between the default and the paper preset, one at a time.

Protocol (fixed, small; CPU is scarce): the synthetic dataset (seed 0); per interaction, train on its
first ``--train`` instances and synthesize its next ``--test`` instances (the same generated pairs of
actors recur, so this is an optimistic, pair-overlapping split), ``--iterations`` MCMC iterations,
seed 0. Synthesis is **causal**: Algorithm 2 with ``SynthesisConfig()`` (the default) or the preset's,
T0 = 10, agent 0 read up to the current frame only. Reported per row:

* ``parse acc``: frame accuracy of the learned training parses against the ground-truth sub-events,
  after the optimal one-to-one label matching, mean over the interactions;
* ``MH accepted``: accepted / proposed Metropolis-Hastings moves per dynamics, summed over the interactions;
* ``key err``: average distance (m) of agent 1's five key joints over the synthesized frames, mean over
  the test instances and interactions (causal).

Rows: ``default``; each difference switched to the paper's value alone (model, learner or synthesizer
field); ``paper`` (all of them). A synthesis-only row reuses the default's fitted models.

Run: ``OMP_NUM_THREADS=1 nice python scripts/preset_ablation.py [--interactions shake_hands high_five]
[--train 12] [--test 4] [--iterations 30] [--rows NAME ...]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from socialaff_sim.data import load_dataset
from socialaff_sim.evaluation.metrics import mean_joint_distance
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference import synthesize
from socialaff_sim.inference.presets import Preset, preset
from socialaff_sim.learning.mh import MOVES
from socialaff_sim.learning.estimator import SocialAffordanceModel

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # run as `python scripts/preset_ablation.py` it is sys.path[0]
    sys.path.append(_HERE)
from mh_moves import parse_accuracy  # noqa: E402  (one definition, shared with the MH-moves script)

# (row name, which config, field): the paper's value is read from the paper preset.
DIFFERENCES: tuple[tuple[str, str, str], ...] = (
    ("other-side reference", "affordance", "other_side_reference"),
    ("reference includes the joint", "affordance", "reference_self"),
    ("learned p(s1)", "affordance", "start_prior"),
    ("one interval per type", "affordance", "unique_labels"),
    ("path noise", "affordance", "path_noise"),
    ("active hand", "affordance", "active_hand"),
    ("hard-EM start", "learning", "init_rounds"),
    ("type restructuring", "learning", "init_type_passes"),
    ("shift move", "learning", "p_shift"),
    ("tempering", "learning", "temperature"),
    ("dz sign term", "synthesis", "vertical_sign"),
    ("open-interval score", "synthesis", "open_interval"),
    ("bounded parse window", "synthesis", "parse_window"),
)


def rows_to_run(only: list[str] | None) -> list[tuple[str, Preset]]:
    default, paper = preset("default"), preset("paper")
    out = [("default", default)]
    for name, part, field in DIFFERENCES:
        cfg = dataclasses.replace(getattr(default, part), **{field: getattr(getattr(paper, part), field)})
        out.append((f"{field} → {getattr(getattr(paper, part), field)!r} ({name})", dataclasses.replace(default, **{part: cfg})))
    out.append(("paper (all of the above)", paper))
    return [r for r in out if only is None or any(o in r[0] for o in only)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--interactions", nargs="*", default=["shake_hands", "high_five"])
    ap.add_argument("--train", type=int, default=12)
    ap.add_argument("--test", type=int, default=4)
    ap.add_argument("--iterations", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rows", nargs="*", default=None, help="only rows whose name contains one of these")
    args = ap.parse_args()
    data = load_dataset("synthetic")
    print(f"protocol: synthetic seed 0, {', '.join(args.interactions)}; train first {args.train}, test next {args.test} "
          f"(same actors in training and test: optimistic); {args.iterations} iterations; causal synthesis, T0 = 10; seed {args.seed}")
    print("| row | parse acc | MH accepted (merge, split, relabel, shift) | key err (m), causal | seconds |")
    print("|---|---|---|---|---|")
    models: dict[tuple[str, str], SocialAffordanceModel] = {}
    for name, p in rows_to_run(args.rows):
        clock = time.perf_counter()
        accs, errs = [], []
        moves = np.zeros((len(MOVES), 2), np.int64)
        for label in args.interactions:
            inters = list(data.of_label(label))
            train, test = inters[: args.train], inters[args.train : args.train + args.test]
            key = (repr((p.affordance, p.learning)), label)
            if key not in models:
                learning = dataclasses.replace(p.learning, iterations=args.iterations)
                models[key] = SocialAffordanceModel(p.affordance, learning).fit(train, rng=np.random.default_rng(args.seed))
            model = models[key]
            accs.append(parse_accuracy(train, model.parses_, model.n_subevents_))
            for m, mv in enumerate(MOVES):
                moves[m] += (int(model.history_[f"proposed_{mv}"].sum()), int(model.history_[f"accepted_{mv}"].sum()))
            for k, inter in enumerate(test):
                T0 = p.synthesis.n_observed
                keys = synthesize(model, observed_part(inter, T0), rng=np.random.default_rng(args.seed + k), config=p.synthesis)[0]
                mask = inter.key_valid()[T0:, 1] & inter.key_available()[None]
                errs.append(mean_joint_distance(keys[T0:], inter.key_joints()[T0:, 1], mask))
        mh = ", ".join(f"{a}/{n}" if n else "—" for n, a in moves)
        print(f"| {name} | {np.mean(accs):.3f} | {mh} | {np.mean(errs):.3f} | {time.perf_counter() - clock:.0f} |", flush=True)


if __name__ == "__main__":
    main()
