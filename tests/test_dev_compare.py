"""scripts/dev_compare.py: the two-seed statistic (mean of two seeds' pooled differences, the paired bootstrap over
instances pooling both seeds) against a brute-force computation, and the one-seed row."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import load_script

dev_compare = load_script("dev_compare")


def _brute(base: list[np.ndarray], other: list[np.ndarray], n_resamples: int, seed: int) -> tuple[float, float, float]:
    """Resample by resample, instance by instance: each resample draws n instances once (the same draws as
    paired_difference's generator makes), and takes the mean over the two seeds of the drawn instances' pooled
    difference."""
    n = base[0].size
    idx = np.random.default_rng(seed).integers(0, n, size=(n_resamples, n))
    stats = []
    for row in idx:
        per_seed = []
        for b, o in zip(base, other, strict=True):
            per_seed.append(sum(o[i] - b[i] for i in row) / n)
        stats.append(sum(per_seed) / 2)
    point = sum(sum(o[i] - b[i] for i in range(n)) / n for b, o in zip(base, other, strict=True)) / 2
    lo, hi = np.percentile(stats, [2.5, 97.5])
    return point, float(lo), float(hi)


def test_two_seed_difference_matches_brute_force(rng: np.random.Generator) -> None:
    n = 23
    base = [rng.uniform(0.1, 0.3, size=n) for _ in range(2)]
    # seed-correlated instance effects, so pairing the instances across seeds matters
    effect = rng.normal(0.0, 0.02, size=n)
    other = [b + effect + rng.normal(0.003, 0.004, size=n) for b in base]
    got = dev_compare.two_seed_difference((base[0], base[1]), (other[0], other[1]), np.random.default_rng(7))
    # same draws, computed through paired_difference's n_resamples default
    ref = _brute(base, other, 10_000, 7)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    # the point is the mean of the two seeds' own pooled differences
    np.testing.assert_allclose(got[0], np.mean([(o - b).mean() for b, o in zip(base, other, strict=True)]), atol=1e-15)


def test_pairing_across_seeds_is_by_instance(rng: np.random.Generator) -> None:
    """Instance effects shared by both seeds widen the interval only if the seeds are paired by instance: shuffling
    the second seed's instances (breaking the pairing) must give a narrower interval here."""
    n = 40
    effect = rng.normal(0.0, 0.03, size=n)
    base = [np.full(n, 0.2), np.full(n, 0.2)]
    other = [0.2 + effect + rng.normal(0, 0.001, n), 0.2 + effect + rng.normal(0, 0.001, n)]
    _, lo, hi = dev_compare.two_seed_difference((base[0], base[1]), (other[0], other[1]), np.random.default_rng(0))
    perm = rng.permutation(n)
    _, lo2, hi2 = dev_compare.two_seed_difference((base[0], base[1][perm]), (other[0], other[1][perm]),
                                                  np.random.default_rng(0))
    assert (hi - lo) > 1.25 * (hi2 - lo2)


def _write(path: Path, rng: np.random.Generator, counts: dict[str, int], shift: float) -> dict:
    e = {c: {"hold": list(np.full(k, 1.0)), "plan": list(rng.uniform(0.2, 0.4, k) + shift),
             "sw:default": list(rng.uniform(0.1, 0.3, k) + shift)} for c, k in counts.items()}
    path.write_text(json.dumps(e))
    return e


def test_cli_two_seeds(tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str],
                       monkeypatch: pytest.MonkeyPatch) -> None:
    counts = {"a": 5, "b": 7}
    files = [tmp_path / f"{k}.json" for k in ("b2", "o2", "b3", "o3")]
    es = [_write(f, rng, counts, s) for f, s in zip(files, (0.0, 0.01, 0.0, 0.02), strict=True)]
    monkeypatch.setattr(sys, "argv", ["dev_compare", *map(str, files[:2]), "--second", *map(str, files[2:]), "--per-class"])
    dev_compare.main()
    out = capsys.readouterr().out
    pool = [np.concatenate([e[c]["sw:default"] for c in counts]) for e in es]
    mean = 0.5 * ((pool[1] - pool[0]).mean() + (pool[3] - pool[2]).mean())
    assert f"| 12 | 1.0000 | {0.5 * (pool[0].mean() + pool[2].mean()):.4f} |" in out
    assert f"| {mean:+.4f} [" in out
    assert f"per seed {(pool[1] - pool[0]).mean():+.4f}, {(pool[3] - pool[2]).mean():+.4f}" in out
    a_base = 0.5 * (np.mean(es[0]["a"]["sw:default"]) + np.mean(es[2]["a"]["sw:default"]))
    assert f"a {a_base:.4f} → " in out


def test_cli_rejects_other_instance_counts(tmp_path: Path, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    files = [tmp_path / f"{k}.json" for k in ("b2", "o2", "b3", "o3")]
    for f in files[:3]:
        _write(f, rng, {"a": 5}, 0.0)
    _write(files[3], rng, {"a": 4}, 0.0)
    monkeypatch.setattr(sys, "argv", ["dev_compare", *map(str, files[:2]), "--second", *map(str, files[2:])])
    with pytest.raises(SystemExit, match="o3.json: class a: expected 5 instances"):
        dev_compare.main()


def test_cli_one_seed(tmp_path: Path, rng: np.random.Generator, capsys: pytest.CaptureFixture[str],
                      monkeypatch: pytest.MonkeyPatch) -> None:
    files = [tmp_path / f"{k}.json" for k in ("b", "o")]
    es = [_write(f, rng, {"a": 6, "b": 3}, s) for f, s in zip(files, (0.0, -0.01), strict=True)]
    monkeypatch.setattr(sys, "argv", ["dev_compare", *map(str, files)])
    dev_compare.main()
    out = capsys.readouterr().out
    pool = [np.concatenate([e[c]["sw:default"] for c in ("a", "b")]) for e in es]
    m, lo, hi = dev_compare.paired_difference([pool[1] - pool[0]], rng=np.random.default_rng(0))
    assert f"| {m:+.4f} [{lo:+.4f}, {hi:+.4f}] |" in out and "changed 9/9" in out


def test_cli_other_key_compares_two_variants_of_one_run(tmp_path: Path, rng: np.random.Generator,
                                                        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """``--other-key``: the other side reads another variant (here of the same files, at two seeds); the figures are
    the two variants' own (swapping the keys flips the sign), and the same file without it is refused."""
    files = [tmp_path / f"s{k}.json" for k in (4, 5)]
    es = []
    for f in files:
        e = _write(f, rng, {"a": 5, "b": 4}, 0.0)
        for c in e:
            e[c]["sw:bag"] = list(np.asarray(e[c]["sw:default"]) - rng.uniform(0.0, 0.01, len(e[c]["sw:default"])))
        f.write_text(json.dumps(e))
        es.append(e)
    pool = {k: [np.concatenate([e[c][k] for c in ("a", "b")]) for e in es] for k in ("sw:default", "sw:bag")}
    mean = 0.5 * sum((pool["sw:bag"][i] - pool["sw:default"][i]).mean() for i in range(2))
    for key, other, sign in (("sw:default", "sw:bag", 1.0), ("sw:bag", "sw:default", -1.0)):
        monkeypatch.setattr(sys, "argv", ["dev_compare", str(files[0]), str(files[0]), "--key", key, "--other-key", other,
                                          "--second", str(files[1]), str(files[1])])
        dev_compare.main()
        assert f"| {sign * mean:+.4f} [" in capsys.readouterr().out
    assert mean < 0
    monkeypatch.setattr(sys, "argv", ["dev_compare", str(files[0]), str(files[0])])
    with pytest.raises(SystemExit, match="distinct files"):
        dev_compare.main()
    monkeypatch.setattr(sys, "argv", ["dev_compare", str(files[0]), str(files[0]), "--other-key", "sw:nope"])
    with pytest.raises(SystemExit, match="sw:nope"):
        dev_compare.main()
