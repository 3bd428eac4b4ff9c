"""Probe for issue 3: does per-instance handedness normalization let Gibbs group the contact joints?

The embedded synthetic actors choose their hand per instance (``left_hand_probability``), so one
grouping per sub-event type cannot fit both hands (docs/analysis.md). This probe relabels, per
instance and per agent, the left and right joints of an agent whose left wrist travels farther than
its right (a pure relabelling, no reflection), fits the model on 18 such instances per interaction
and reports, as ``bench_learning.py`` does, the frame accuracy and whether the contact joints share
a group. It is a probe, not a feature: synthesis would have to map the labels back.

    OMP_NUM_THREADS=1 python scripts/probe_handedness.py [--iterations 100] [--seed 0] [--interactions ...]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from bench_learning import CONTACT, SUBEVENTS, contact_joints, frame_accuracy  # noqa: E402

from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.data.synthetic import INTERACTIONS, generate_dataset  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402
from socialaff_sim.model.affordance import SocialAffordanceModel  # noqa: E402


def active_hand_right(inter: Interaction) -> Interaction:
    """The instance with each agent's left/right joints swapped where its left wrist travels farther."""
    names = list(inter.layout.joint_names)
    swap = np.array([names.index("right_" + n[5:]) if n.startswith("left_") else
                     names.index("left_" + n[6:]) if n.startswith("right_") else i for i, n in enumerate(names)])
    lw, rw = names.index("left_wrist"), names.index("right_wrist")
    joints, valid = inter.joints.copy(), np.array(inter.valid, copy=True)
    filled = inter.filled_joints()
    for a in range(2):
        path = np.linalg.norm(np.diff(filled[:, a, [lw, rw]], axis=0), axis=-1).sum(axis=0)
        if path[0] > path[1]:
            joints[:, a], valid[:, a] = joints[:, a][:, swap], valid[:, a][:, swap]
    return inter.replace(joints=joints, valid=valid)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--iterations", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--interactions", nargs="*", default=list(INTERACTIONS))
    args = ap.parse_args()
    data = generate_dataset(args.seed)
    print(f"{'interaction':12s} {'acc':>6s} {'grouped':>8s}  contact joints -> grouping of the contact type")
    for label in args.interactions:
        inters = [active_hand_right(i) for i in list(data.of_label(label))[:18]]
        model = SocialAffordanceModel(learning=LearningConfig(iterations=args.iterations)).fit(
            inters, rng=np.random.default_rng(args.seed))
        acc, match = frame_accuracy(model, inters)
        joints = contact_joints(label, inters)
        hit = np.flatnonzero(match == SUBEVENTS[label].index(CONTACT[label]))
        z = model.grouping_[int(hit[0])] if hit.size else None
        grouped = z is not None and bool(z[joints[0]] > 0 and all(z[j] == z[joints[0]] for j in joints))
        print(f"{label:12s} {acc:6.3f} {str(grouped):>8s}  {joints} -> {None if z is None else z.tolist()}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
