"""Benchmark of the affordance model's learning (Algorithm 1) on the synthetic dataset.

For each interaction, fit a model on the first N instances (default 18) with the default
configuration (one core: run it alone) and report

* ``acc``: frame accuracy of the learned training parses against the ground-truth sub-events
  after the optimal one-to-one matching of labels (scipy.optimize.linear_sum_assignment);
* ``grouped``: in the learned type matched to the contact sub-event (shake, strike, pull, catch,
  transfer), whether the joints that touch share a group. The touching joints are found from
  the data: the closest agent-0/agent-1 wrist pair at the end of the ground-truth contact
  sub-event (majority over instances) plus the object where there is one; for throw_catch,
  where the ball reaches the catcher, the catcher's closest wrist and the ball;
* seconds of the K-means atoms, of the initial parses (hard-EM) and of the MCMC
  (``--iterations`` outer iterations, default 100);
* with ``--diagnose``: log P* of the learned state, of the ground-truth parses snapped to the
  atomic intervals, and of those refined by the same hard-EM the learner uses — whether the
  model's objective prefers the ground-truth segmentation.

The model's optional corrections (see :class:`~socialaff_sim.model.config.AffordanceConfig` and
:class:`~socialaff_sim.learning.config.LearningConfig`; the defaults otherwise; ``*.paper()`` for the paper's) are switched with
``--likelihood held_out``, ``--vector-density cartesian``, ``--duration-density log_seconds`` and
``--init-starts N``; ``--active-hand off`` keeps each agent's left/right labels as recorded (the paper).

Run: ``python scripts/bench_learning.py [--instances 18] [--iterations 100] [--seed 0] [--diagnose] [--p-shift P]
[--interactions NAME ...] [--likelihood L] [--vector-density D] [--duration-density D] [--init-starts N] [--active-hand on|off]
[--json PATH]``; ``--json`` also writes the table (and the settings) to PATH, atomically.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections import Counter

import numpy as np
from scipy.optimize import linear_sum_assignment

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.data.synthetic import SUBEVENTS, SyntheticConfig, generate_dataset
from socialaff_sim.learning.algorithm import make_spaces
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.initial import hard_em_parses
from socialaff_sim.learning.parse import Parse, ParseSpace
from socialaff_sim.learning.scorer import AffordanceTarget
from socialaff_sim.learning.atomic import AtomicIntervals, motion_change
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.joints import JOINT_NAMES, OBJECT

CONTACT = {"shake_hands": "shake", "high_five": "strike", "pull_up": "pull", "throw_catch": "catch", "hand_over": "transfer"}
WRISTS = (1, 2)  # left, right key-joint indices


def frame_accuracy(model: SocialAffordanceModel, inters) -> tuple[float, np.ndarray]:  # noqa: ANN001
    """Accuracy after optimal matching, and the matching (learned label -> ground-truth index)."""
    S = model.n_subevents_
    G = len(inters[0].subevent_names)
    C = np.zeros((S, G))
    for inter, rows in zip(inters, model.parses_, strict=True):
        lab = np.empty(inter.n_frames, dtype=np.int64)
        for f0, f1, s in rows:
            lab[f0:f1] = s
        ok = inter.subevents >= 0
        np.add.at(C, (lab[ok], inter.subevents[ok]), 1)
    r, c = linear_sum_assignment(-C)
    match = np.full(S, -1)
    match[r] = c
    return float(C[r, c].sum() / C.sum()), match


def contact_joints(label: str, inters, model: SocialAffordanceModel) -> tuple[int, ...]:  # noqa: ANN001
    """Model joint indices that touch in the contact sub-event (majority over instances), in the
    model's labels (after its active-hand relabelling, when on)."""
    gt = SUBEVENTS[label].index(CONTACT[label])
    votes: Counter = Counter()
    for inter in inters:
        x = model.canonical_track(inter)
        t = np.flatnonzero(inter.subevents == gt)[-1]
        if label == "throw_catch":
            d = [np.linalg.norm(x[t, 5 + w] - x[t, OBJECT]) for w in WRISTS]
            votes[(5 + WRISTS[int(np.argmin(d))], OBJECT)] += 1
            continue
        _, a, b = min((np.linalg.norm(x[t, a] - x[t, 5 + b]), a, 5 + b) for a in WRISTS for b in WRISTS)
        votes[(a, b) + ((OBJECT,) if inter.has_object else ())] += 1
    return votes.most_common(1)[0][0]


def gt_parse(space: ParseSpace, sub: np.ndarray) -> Parse:
    """The ground-truth sub-events snapped to the nearest atomic boundaries."""
    cuts = np.flatnonzero(sub[1:] != sub[:-1]) + 1
    starts, labels = [0], [int(sub[0])]
    for c in cuts:
        b = int(np.argmin(np.abs(space.bounds - c)))
        if 0 < b < space.n_atoms and b > starts[-1]:
            starts.append(b)
            labels.append(int(sub[c]))
    return Parse(tuple(starts), tuple(labels))


def diagnose(model: SocialAffordanceModel, inters, seed: int) -> tuple[float, float]:  # noqa: ANN001
    """log P* of the ground-truth parses (snapped) and of their hard-EM refinement."""
    tracks = [model.canonical_track(i) for i in inters]
    fps = [i.fps for i in inters]
    bounds = [model.atom_bounds(i, t) for i, t in zip(inters, tracks, strict=True)]
    change = [motion_change(t, model.available_, b, f) for t, b, f in zip(tracks, bounds, fps, strict=True)]
    atoms = AtomicIntervals(model.centroids_, tuple(bounds), tuple(change))
    S = model.n_subevents_
    spaces = make_spaces(atoms, S, model.config)
    gt = [gt_parse(sp, i.subevents) for sp, i in zip(spaces, inters, strict=True)]
    rng = np.random.default_rng(seed)
    args = (tracks, fps, spaces)
    p_gt = AffordanceTarget(*args, gt, model.available_, S, model.config, model.learning, rng).log_prob
    em = hard_em_parses(*args, gt, model.available_, S, model.config, model.learning, rng=rng, rounds=model.learning.init_rounds)
    p_em = AffordanceTarget(*args, em, model.available_, S, model.config, model.learning, rng).log_prob
    return p_gt, p_em


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--instances", type=int, default=18, help="training instances per interaction (default 18)")
    ap.add_argument("--iterations", type=int, default=100, help="outer MCMC iterations (default 100)")
    ap.add_argument("--seed", type=int, default=0, help="dataset seed and fit seed (default 0)")
    ap.add_argument("--interactions", nargs="*", default=None, help="subset of the interactions")
    ap.add_argument("--diagnose", action="store_true", help="also score the ground-truth parses under the model")
    ap.add_argument("--p-shift", type=float, default=None, help="override LearningConfig.p_shift (0: no shift move, as in the paper)")
    ap.add_argument("--likelihood", default=None, help="override AffordanceConfig.likelihood (profile, held_out)")
    ap.add_argument("--vector-density", default=None, help="override AffordanceConfig.vector_density (polar, cartesian)")
    ap.add_argument("--duration-density", default=None,
                    help="override AffordanceConfig.duration_density (seconds, log_seconds)")
    ap.add_argument("--init-starts", type=int, default=None, help="override LearningConfig.init_starts")
    ap.add_argument("--init-type-passes", type=int, default=None, help="override LearningConfig.init_type_passes")
    ap.add_argument("--path-noise", choices=("on", "off"), default=None, help="override AffordanceConfig.path_noise")
    ap.add_argument("--active-hand", choices=("on", "off"), default=None,
                    help="override AffordanceConfig.active_hand (off: the paper's labels as recorded)")
    ap.add_argument("--path-profile", default=None, help="override AffordanceConfig.path_profile (minjerk, linear)")
    ap.add_argument("--left-hand-probability", type=float, default=None,
                    help="override SyntheticConfig.left_hand_probability (0: every one-handed action uses the right hand)")
    ap.add_argument("--json", default=None, help="also write the table here (atomically)")
    args = ap.parse_args()
    synth = SyntheticConfig() if args.left_hand_probability is None else SyntheticConfig(
        left_hand_probability=args.left_hand_probability)
    data = generate_dataset(seed=args.seed, config=synth)
    learning = dataclasses.replace(LearningConfig(), iterations=args.iterations)
    if args.p_shift is not None:
        learning = dataclasses.replace(learning, p_shift=args.p_shift)
    if args.init_starts is not None:
        learning = dataclasses.replace(learning, init_starts=args.init_starts)
    if args.init_type_passes is not None:
        learning = dataclasses.replace(learning, init_type_passes=args.init_type_passes)
    overrides = {"likelihood": args.likelihood, "vector_density": args.vector_density,
                 "duration_density": args.duration_density, "path_profile": args.path_profile,
                 "path_noise": None if args.path_noise is None else args.path_noise == "on",
                 "active_hand": None if args.active_hand is None else args.active_hand == "on"}
    config = AffordanceConfig(**{k: v for k, v in overrides.items() if v is not None})
    accs = []
    rows: dict[str, dict] = {}
    head = f"{'interaction':12s} {'acc':>6s} {'grouped':>8s} {'atoms s':>8s} {'init s':>7s} {'mcmc s':>7s} {'accept':>7s}"
    print(head + ("  log P*: learned / GT / GT+EM" if args.diagnose else "") + "  contact joints -> grouping of that type")
    for label in args.interactions or data.labels:
        inters = list(data.of_label(label))[: args.instances]
        model = SocialAffordanceModel(config, learning)
        model.fit(inters, rng=np.random.default_rng(args.seed))
        acc, match = frame_accuracy(model, inters)
        gt_index = SUBEVENTS[label].index(CONTACT[label])
        s = int(np.flatnonzero(match == gt_index)[0]) if (match == gt_index).any() else -1
        joints = contact_joints(label, inters, model)
        z = model.grouping_[s] if s >= 0 else np.zeros(len(JOINT_NAMES), int)
        grouped = bool(z[joints[0]] > 0 and all(z[j] == z[joints[0]] for j in joints))
        accs.append(acc)
        sec = model.fit_seconds_
        line = (f"{label:12s} {acc:6.3f} {str(grouped):>8s} {sec['atoms']:8.2f} {sec['init']:7.2f} "
                f"{sec['mcmc']:7.2f} {model.acceptance_rate_:7.3f}")
        if args.diagnose:
            p_gt, p_em = diagnose(model, inters, args.seed)
            line += f"  {model.log_posterior_:8.1f} / {p_gt:8.1f} / {p_em:8.1f}"
        names = ",".join(JOINT_NAMES[j] for j in joints)
        print(f"{line}  {names} -> {z.tolist()}", flush=True)
        rows[label] = {
            "instances": len(inters), "frame_accuracy": acc, "contact_joints_grouped": grouped,
            "contact_joints": [JOINT_NAMES[j] for j in joints], "grouping": z.tolist(),
            "atoms_s": sec["atoms"], "init_s": sec["init"], "mcmc_s": sec["mcmc"],
            "fit_s": sec["atoms"] + sec["init"] + sec["mcmc"], "acceptance": model.acceptance_rate_,
        }
        if args.diagnose:
            rows[label].update(log_p_learned=model.log_posterior_, log_p_gt=p_gt, log_p_gt_em=p_em)
    print(f"mean frame accuracy {np.mean(accs):.3f} over {len(accs)} interactions")
    print(f"config: {config}; init_starts={learning.init_starts}; init_type_passes={learning.init_type_passes}")
    if args.json:
        result = {
            "seed": args.seed, "instances": args.instances, "iterations": args.iterations,
            "config": repr(config), "learning": repr(learning), "seconds_clock": "wall (time.perf_counter)",
            "interactions": rows, "mean_frame_accuracy": float(np.mean(accs)),
        }
        atomic_write_text(args.json, json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
