"""Who pushes in SBU's pushing recordings (class 04): the evidence behind envs/pushing.toml.

Per recording and agent a: the nearest approach, over all frames, of either of a's hands (SBU joints left_hand,
right_hand) to the other agent's trunk (neck, torso, left and right shoulder joints), metres. The pusher is the
agent whose hands come nearer, by at least :data:`MARGIN`; closer than that the recording is ``ambiguous``.
Printed: one line per recording, the counts, and per set (the two actors' session) whether its two takes are
pushed the same way. Example::

    python scripts/pushing_roles.py ../shared/data/sbu_kinect_interaction

The library never imports this script.
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

import numpy as np

from socialaff_sim.data.interaction import Interaction
from socialaff_sim.data.specs import load_dataset

__all__ = ["MARGIN", "hand_to_trunk", "pusher", "roles"]

MARGIN = 0.05
"""m: the nearer agent's hands must be this much nearer the other's trunk to be named the pusher."""
HANDS = ("left_hand", "right_hand")
TRUNK = ("neck", "torso", "left_shoulder", "right_shoulder")


def hand_to_trunk(inter: Interaction, agent: int) -> float:
    """Nearest approach (m) of ``agent``'s hands to the other agent's trunk joints over the recording."""
    names = inter.joint_names
    hands = inter.joints[:, agent][:, [names.index(n) for n in HANDS]]
    trunk = inter.joints[:, 1 - agent][:, [names.index(n) for n in TRUNK]]
    return float(np.linalg.norm(hands[:, :, None] - trunk[:, None], axis=-1).min())


def pusher(inter: Interaction, margin: float = MARGIN) -> str:
    """``agent0``, ``agent1`` or ``ambiguous`` (:data:`MARGIN`)."""
    d0, d1 = hand_to_trunk(inter, 0), hand_to_trunk(inter, 1)
    if abs(d0 - d1) < margin:
        return "ambiguous"
    return "agent0" if d0 < d1 else "agent1"


def roles(insts: list[Interaction]) -> tuple[Counter, dict[str, list[str]]]:
    """Counts of :func:`pusher` and, per set (instance id up to the first ``_``), its takes' pushers in order."""
    sets: dict[str, list[str]] = {}
    for inter in insts:
        sets.setdefault(inter.instance_id.split("_")[0], []).append(pusher(inter))
    return Counter(p for v in sets.values() for p in v), sets


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("root", type=Path, help="the SBU folder (../shared/data/sbu_kinect_interaction)")
    args = p.parse_args(argv)
    insts = list(load_dataset(f"sbu:{args.root}").of_label("pushing").interactions)
    for inter in insts:
        print(f"{inter.instance_id}: agent 0's hands to agent 1's trunk {hand_to_trunk(inter, 0):.2f} m, agent 1's to "
              f"agent 0's {hand_to_trunk(inter, 1):.2f} m: {pusher(inter)}")
    counts, sets = roles(insts)
    two = {s: v for s, v in sets.items() if len(v) == 2 and "ambiguous" not in v}
    swapped = sum(v[0] != v[1] for v in two.values())
    print(f"{len(insts)} recordings: " + ", ".join(f"{k} {counts[k]}" for k in ("agent0", "agent1", "ambiguous")))
    print(f"sets with two unambiguous takes: {len(two)}; pushed one each way: {swapped}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
