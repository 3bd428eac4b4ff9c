"""Does the Metropolis-Hastings chain move? Acceptance per dynamics and parse agreement, both presets.

For each data set and interaction, fit the model with the ``default`` and the ``paper`` preset
(:func:`socialaff_sim.inference.presets.preset`) and report, per dynamics, proposals and acceptances
(``model.history_``), and, where the data carry ground-truth sub-events (the synthetic set), the frame
accuracy after the optimal one-to-one label matching of three parses of the training instances: the
equal parts of the K-means atoms (the paper's start, ``init``), the chain's first state (``start``:
after hard-EM and type restructuring in the default, the same as ``init`` in the paper) and the
learned parse (``learned``).

Run: ``OMP_NUM_THREADS=1 python scripts/mh_moves.py [--data synthetic] [--interactions shake_hands high_five]
[--instances 12] [--iterations 30] [--presets default paper] [--seed 0]``.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from socialaff_sim.data import load_dataset
from socialaff_sim.inference.presets import preset
from socialaff_sim.evaluation.metrics import matched_accuracy, parse_confusion
from socialaff_sim.learning.algorithm import learn
from socialaff_sim.learning.history import acceptance_rates
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.model.handedness import hand_flags, relabel
from socialaff_sim.model.joints import available_joints, canonical_joints


def parse_accuracy(inters, parses, S: int) -> float:  # noqa: ANN001
    """Frame accuracy of labelled spans ``(f0, f1, s)`` against the instances' ground-truth sub-events, after the
    one-to-one label matching that maximizes it over all instances together (evaluation.metrics)."""
    G = len(inters[0].subevent_names)
    C = np.zeros((G, S), dtype=np.int64)
    total = 0
    for inter, rows in zip(inters, parses, strict=True):
        labels = np.full(len(inter.subevents), -1, dtype=np.int64)
        for f0, f1, s in rows:
            labels[f0:f1] = s
        c = parse_confusion(labels, inter.subevents, G)
        C[:, : c.shape[1]] += c
        total += int((inter.subevents >= 0).sum())
    return matched_accuracy(C, total)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default="synthetic")
    ap.add_argument("--interactions", nargs="*", default=["shake_hands", "high_five"])
    ap.add_argument("--instances", type=int, default=12)
    ap.add_argument("--iterations", type=int, default=30)
    ap.add_argument("--presets", nargs="*", default=["default", "paper"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--temperature", type=float, default=None, help="override LearningConfig.temperature (T0) of every preset")
    args = ap.parse_args()
    data = load_dataset(args.data)
    print(f"data {args.data}, {args.instances} instances, {args.iterations} iterations, seed {args.seed}, "
          f"temperature {args.temperature if args.temperature is not None else 'of the preset'}")
    print("| preset | interaction | merge | split | relabel | shift | init acc | start acc | learned acc | log P* start -> end |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label in args.interactions:
        inters = list(data.of_label(label))[: args.instances]
        for name in args.presets:
            p = preset(name)
            learning = dataclasses.replace(p.learning, iterations=args.iterations)
            if args.temperature is not None:
                learning = dataclasses.replace(learning, temperature=args.temperature)
            model = SocialAffordanceModel(p.affordance, learning).fit(inters, rng=np.random.default_rng(args.seed))
            rates = acceptance_rates(model.history_)
            cells = [f"{a}/{n} ({r:.1%})" if (n := rates.get(m, (0, 0, 0))[0]) else "—"
                     for m in ("merge", "split", "relabel", "shift") for (_, a, r) in [rates.get(m, (0, 0, 0.0))]]
            has_gt = all(i.subevents is not None for i in inters)
            S = model.n_subevents_
            accs = ["—", "—", "—"]
            if has_gt:
                # The same atoms and start as the fit (same seed): re-run only the initialisation, no iterations.
                raw = [canonical_joints(i) for i in inters]
                tracks = [relabel(x, hand_flags(x)) if p.affordance.active_hand else x for x in raw]
                res = learn(tracks, [i.fps for i in inters], available_joints(tracks), S, p.affordance,
                            dataclasses.replace(learning, iterations=0), rng=np.random.default_rng(args.seed))
                init = [sp.frame_spans(sp.initial_parse(S)) for sp in res.spaces]
                start = [sp.frame_spans(q) for sp, q in zip(res.spaces, res.start_parses, strict=True)]
                learned = [[tuple(r) for r in rows] for rows in model.parses_]
                accs = [f"{parse_accuracy(inters, x, S):.3f}" for x in (init, start, learned)]
            lp = model.history_["log_posterior"]
            print(f"| {name} | {label} | {' | '.join(cells)} | {' | '.join(accs)} | {lp[0]:.0f} -> {lp[-1]:.0f} |", flush=True)


if __name__ == "__main__":
    main()
