"""Paired comparison of ``scripts/dev_switching.py --errors`` files of one development split (issue 24).

Prints, for the pooled validation instances, ``hold``, the two runs' mean ``sw:default`` (or ``--key``) key-joint
error, the paired 95 % percentile bootstrap of their difference (``paired_difference``, seed 0), Algorithm 2's plan alone
in both, and how many instances changed. Usage::

    python scripts/dev_compare.py BASE.json OTHER.json [--key sw:default] [--label NAME] [--per-class]
    python scripts/dev_compare.py BASE.json OTHER.json --second BASE2.json OTHER2.json [...]
    python scripts/dev_compare.py RUN.json RUN.json --key sw:default --other-key sw:default@mean [--second RUN2.json RUN2.json]

``--other-key`` (default: ``--key``) reads the other run's errors under another name, so two variants of one run
compare (the same file as base and other; ``scripts/_dev_draws.py``: the default against itself averaged over its
partition draws).

With ``--second`` (the same split at a second seed; the evaluation's folds do not depend on ``--seed``, so both seeds
validate on the same instances, in the same order) the figures are the means over the two seeds, and the difference is
each instance's difference averaged over the two seeds, then over the instances (= the mean of the two seeds' pooled
differences); its interval is the paired bootstrap over instances pooling both seeds: each resample draws the split's
instances once, with replacement, and averages the drawn instances' seed-averaged differences (``paired_difference``
on them, seed 0). Each seed's own pooled difference is printed beside it.

Only development-split files; the library never imports this script.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from socialaff_sim.evaluation.compare import paired_difference

Errors = dict[str, dict[str, list[float]]]


def load(path: str) -> Errors:
    """One ``--errors`` file: {class: {variant: per-instance key-joint m}}."""
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def pooled(errors: Errors, key: str, classes: list[str]) -> np.ndarray:
    """(n,) per-instance errors of ``key``, m, the classes concatenated in ``classes``' order."""
    return np.concatenate([np.asarray(errors[c][key], float) for c in classes])


def check_same_instances(files: dict[str, Errors], key: str) -> list[str]:
    """The classes of the first file; a SystemExit naming the file if another has other classes or counts."""
    name0, first = next(iter(files.items()))
    classes = list(first)
    for name, e in files.items():
        if set(e) != set(classes):
            raise SystemExit(f"{name}: expected the classes {sorted(classes)}, found {sorted(e)}")
        for c in classes:
            if len(e[c][key]) != len(first[c][key]):
                raise SystemExit(f"{name}: class {c}: expected {len(first[c][key])} instances (as {name0}), "
                                 f"found {len(e[c][key])}")
    return classes


def two_seed_difference(base: tuple[np.ndarray, np.ndarray], other: tuple[np.ndarray, np.ndarray],
                        rng: np.random.Generator) -> tuple[float, float, float]:
    """(mean, low, high): the mean over two seeds of the pooled difference other − base, m, and its paired 95 %
    bootstrap over instances pooling both seeds. ``base``/``other``: each seed's (n,) per-instance errors, instance i
    the same recording in both seeds."""
    d = 0.5 * ((other[0] - base[0]) + (other[1] - base[1]))
    return paired_difference([d], rng=rng)


def _per_class(base: list[Errors], other: list[Errors], key: str, other_key: str, classes: list[str]) -> str:
    return "; ".join(f"{c} {np.mean([np.mean(b[c][key]) for b in base]):.4f} → "
                     f"{np.mean([np.mean(o[c][other_key]) for o in other]):.4f}" for c in classes)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("base")
    ap.add_argument("other")
    ap.add_argument("--second", nargs=2, metavar=("BASE2", "OTHER2"), default=None,
                    help="the same split's two files at a second seed (two-seed means and interval)")
    ap.add_argument("--key", default="sw:default")
    ap.add_argument("--other-key", default=None, help="the other run's variant (default: --key)")
    ap.add_argument("--label", default="")
    ap.add_argument("--per-class", action="store_true", help="also each class's mean error, base → other")
    args = ap.parse_args()
    names = [args.base, args.other] + (list(args.second) if args.second else [])
    other_key = args.other_key or args.key
    files = {n: load(n) for n in names}
    if len(files) != len(names) and other_key == args.key:
        raise SystemExit("expected distinct files for the base and other runs (or --other-key)")
    classes = check_same_instances(files, args.key)
    errs = [files[n] for n in names]
    base, other = errs[0::2], errs[1::2]
    for n in names[1::2]:
        if any(other_key not in files[n][c] for c in classes):
            raise SystemExit(f"{n}: expected the variant {other_key!r} in every class")
    b = [pooled(e, args.key, classes) for e in base]
    o = [pooled(e, other_key, classes) for e in other]
    pb = [pooled(e, "plan", classes) for e in base]
    po = [pooled(e, "plan", classes) for e in other]
    hold = pooled(base[0], "hold", classes)
    if args.second:
        m, lo, hi = two_seed_difference((b[0], b[1]), (o[0], o[1]), np.random.default_rng(0))
        per_seed = ", ".join(f"{(oo - bb).mean():+.4f}" for bb, oo in zip(b, o, strict=True))
        extra = f" per seed {per_seed} |"
    else:
        m, lo, hi = paired_difference([o[0] - b[0]], rng=np.random.default_rng(0))
        extra = f" changed {int((o[0] != b[0]).sum())}/{b[0].size} |"
    print(f"| {args.label or args.other} | {hold.size} | {hold.mean():.4f} | {np.mean([x.mean() for x in b]):.4f} | "
          f"{np.mean([x.mean() for x in o]):.4f} | {m:+.4f} [{lo:+.4f}, {hi:+.4f}] | "
          f"{np.mean([x.mean() for x in pb]):.4f} → {np.mean([x.mean() for x in po]):.4f} |{extra}")
    if args.per_class:
        print(f"per class, {args.key} → {other_key}: {_per_class(base, other, args.key, other_key, classes)}")
        print(f"per class, plan: {_per_class(base, other, 'plan', 'plan', classes)}")


if __name__ == "__main__":
    main()
