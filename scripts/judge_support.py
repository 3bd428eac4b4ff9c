"""Judge a declared rule from two ``scripts/bench_support.py --json`` runs: the baseline (A) and the candidate (B).

Episodes are paired by (robot, mode, interaction, instance); only episodes present in both runs count. Per robot and
mode it prints: successes A → B with the episodes lost and gained; the failure kinds of each arm; the paired mean
difference B − A of the contact-phase outside support (points of the robot's weight) and of the feet's slide (cm)
over the episodes with a contact phase in both, each with a 95 % percentile-bootstrap interval (10,000 resamples of
the episodes, seeded); the arms' means and medians; the largest torso tilt of each arm; successes per interaction.
Where both runs carry per-frame figures (``bench_support.py`` rows since session 36), it also prints the same two
paired differences over the *shared contact frames*: per episode, only the data frames in which a sub-goal's contact
holds in both arms (support: their mean; slide: their sum), so that a candidate that makes or lengthens a contact is
compared with the baseline on the same frames, not on a longer phase.
Usage::

    python scripts/judge_support.py A.json B.json [--robot ours] [--mode standing] [--label high_five] [--seed 0]

The library never imports this script.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
from pathlib import Path

import numpy as np

Key = tuple[str, str, str, str]


def load_rows(path: str) -> dict[Key, dict]:
    """``bench_support.py``'s rows keyed by (robot, mode, label, instance); a one-line error for anything else."""
    try:
        rows = json.loads(Path(path).read_text())["rows"]
        return {(r["robot"], r["mode"], r["label"], r["instance"]): r for r in rows}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"judge_support.py: {path}: expected a bench_support.py --json file with 'rows' ({exc!r})", file=sys.stderr)
        raise SystemExit(2) from None


def bootstrap(d: np.ndarray, rng: np.random.Generator, resamples: int = 10_000) -> tuple[float, float, float]:
    """Mean of ``d`` (n,) and its 95 % percentile-bootstrap interval over the n paired differences."""
    if d.size == 0:
        return float("nan"), float("nan"), float("nan")
    means = d[rng.integers(0, d.size, size=(resamples, d.size))].mean(axis=1)
    return float(d.mean()), float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def shared_frames(ra: dict, rb: dict) -> tuple[float, float, float, float, int] | None:
    """Over the data frames in which both rows' contact holds: (support A, support B) as the mean outside support
    (points of the weight), (slide A, slide B) as the summed slide (cm), and the number of such frames; ``None`` when
    a row lacks per-frame figures or no frame is shared."""
    if any(k not in r for r in (ra, rb) for k in ("frames_contact", "frames_support", "frames_slide_cm")):
        return None
    n = min(len(ra["frames_contact"]), len(rb["frames_contact"]))
    both = (np.asarray(ra["frames_contact"][:n], bool) & np.asarray(rb["frames_contact"][:n], bool))
    if not both.any():
        return None
    sa, sb = (100.0 * float(np.mean(np.asarray(r["frames_support"][:n])[both])) for r in (ra, rb))
    la, lb = (float(np.sum(np.asarray(r["frames_slide_cm"][:n])[both])) for r in (ra, rb))
    return sa, sb, la, lb, int(both.sum())


def report(a: dict[Key, dict], b: dict[Key, dict], keys: list[Key], seed: int) -> list[str]:
    """The lines for one robot and mode (``keys``: its paired episodes)."""
    lost = [k[3] for k in keys if a[k]["success"] and not b[k]["success"]]
    gained = [k[3] for k in keys if b[k]["success"] and not a[k]["success"]]
    both = [k for k in keys if a[k]["contact_frames"] and b[k]["contact_frames"]]
    sup_a = np.array([100.0 * a[k]["outside_support_mean"] for k in both])
    sup_b = np.array([100.0 * b[k]["outside_support_mean"] for k in both])
    sl_a = np.array([a[k]["foot_slide_cm"] for k in both])
    sl_b = np.array([b[k]["foot_slide_cm"] for k in both])
    rng = np.random.default_rng(seed)
    ds, ls, hs = bootstrap(sup_b - sup_a, rng)
    dl, ll, hl = bootstrap(sl_b - sl_a, rng)
    med = lambda x: float(np.median(x)) if x.size else float("nan")  # noqa: E731
    per: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0, 0])
    for k in keys:
        per[k[2]][0] += bool(a[k]["success"])
        per[k[2]][1] += bool(b[k]["success"])
        per[k[2]][2] += 1
    return [
        f"{len(keys)} episodes, {len(both)} with a contact phase in both",
        f"successes {sum(bool(a[k]['success']) for k in keys)} -> {sum(bool(b[k]['success']) for k in keys)}; "
        f"lost {lost}; gained {gained}",
        f"failures A {dict(collections.Counter(f for k in keys for f in a[k]['failures']))}  "
        f"B {dict(collections.Counter(f for k in keys for f in b[k]['failures']))}",
        f"support (points) B-A {ds:+.2f} [{ls:+.2f}, {hs:+.2f}]; mean A {sup_a.mean() if both else float('nan'):.2f} "
        f"B {sup_b.mean() if both else float('nan'):.2f}",
        f"slide (cm) B-A {dl:+.2f} [{ll:+.2f}, {hl:+.2f}]; median A {med(sl_a):.2f} B {med(sl_b):.2f}",
        f"tilt max (deg) A {max(a[k]['episode_tilt_deg_max'] for k in keys):.1f} "
        f"B {max(b[k]['episode_tilt_deg_max'] for k in keys):.1f}",
        "per interaction (A/B of n): " + ", ".join(f"{lab} {x}/{y} of {n}" for lab, (x, y, n) in sorted(per.items())),
    ] + _shared_lines(a, b, keys, seed) + ([  # runs before the outcome codes (sim/outcome.py) have none
        f"outcomes A {dict(collections.Counter(a[k]['outcome'] for k in keys))}  "
        f"B {dict(collections.Counter(b[k]['outcome'] for k in keys))}"]
        if all("outcome" in a[k] and "outcome" in b[k] for k in keys) else [])


def _shared_lines(a: dict[Key, dict], b: dict[Key, dict], keys: list[Key], seed: int) -> list[str]:
    """The shared-contact-frames lines (:func:`shared_frames`), or none when the runs lack per-frame figures."""
    if not all("frames_contact" in a[k] and "frames_contact" in b[k] for k in keys):
        return []
    got = [s for s in (shared_frames(a[k], b[k]) for k in keys) if s is not None]
    arr = np.array([s[:4] for s in got]).reshape(-1, 4)
    rng = np.random.default_rng(seed)
    ds, ls, hs = bootstrap(arr[:, 1] - arr[:, 0], rng)
    dl, ll, hl = bootstrap(arr[:, 3] - arr[:, 2], rng)
    return [f"shared contact frames: {len(got)} episodes, {sum(s[4] for s in got)} frames; "
            f"support (points) B-A {ds:+.2f} [{ls:+.2f}, {hs:+.2f}]; slide (cm) B-A {dl:+.2f} [{ll:+.2f}, {hl:+.2f}]"]


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("a", help="the baseline's bench_support.py --json file")
    p.add_argument("b", help="the candidate's bench_support.py --json file")
    p.add_argument("--robot")
    p.add_argument("--mode")
    p.add_argument("--label")
    p.add_argument("--seed", type=int, default=0, help="the bootstrap's seed (default 0)")
    args = p.parse_args(argv)
    a, b = load_rows(args.a), load_rows(args.b)
    print(f"paired episodes: {len(set(a) & set(b))} (A only {len(set(a) - set(b))}, B only {len(set(b) - set(a))})")
    groups: dict[tuple[str, str], list[Key]] = collections.defaultdict(list)
    for k in sorted(set(a) & set(b)):
        if all(want is None or want == have for want, have in ((args.robot, k[0]), (args.mode, k[1]), (args.label, k[2]))):
            groups[(k[0], k[1])].append(k)
    for (robot, mode), keys in sorted(groups.items()):
        print(f"\n== {robot} / {mode}")
        print("\n".join(report(a, b, keys, args.seed)))


if __name__ == "__main__":
    sys.exit(main())
