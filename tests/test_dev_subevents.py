"""The helpers of scripts/dev_subevents.py (the diagnosis of what the sub-events carry): time alignment against brute
force, the half-way time, and the phases of a transfer read from the object track."""

from __future__ import annotations


import numpy as np
import pytest
from conftest import load_script

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

dev = load_script("dev_subevents")


def _paths(n: int, m: int):  # noqa: ANN202 (Iterator of monotone alignment paths from (0, 0) to (n-1, m-1))
    def walk(i: int, j: int, path: list[tuple[int, int]]):  # noqa: ANN202
        if (i, j) == (n - 1, m - 1):
            yield path
            return
        for di, dj in ((1, 0), (0, 1), (1, 1)):
            if i + di < n and j + dj < m:
                yield from walk(i + di, j + dj, path + [(i + di, j + dj)])
    yield from walk(0, 0, [(0, 0)])


def test_dtw_error_is_the_least_summed_path_over_its_length(rng: np.random.Generator) -> None:
    pred, truth = rng.normal(size=(4, 15)), rng.normal(size=(5, 15))
    cost = np.array([[dev.frame_errors(p[None], q[None]).mean() for q in truth] for p in pred])
    best = min(_paths(4, 5), key=lambda path: sum(cost[i, j] for i, j in path))
    assert dev.dtw_error(pred, truth) == pytest.approx(sum(cost[i, j] for i, j in best) / len(best), rel=1e-12)


def test_dtw_error_removes_a_delay_but_not_a_wrong_shape() -> None:
    t = np.linspace(0.0, 1.0, 30)
    truth = np.tile(t[:, None], (1, 15))
    late = np.tile(np.clip(t - 0.2, 0.0, None)[:, None], (1, 15))  # the same path, 6 frames late
    raw = dev.frame_errors(late, truth).mean()
    assert raw > 0.1 and dev.dtw_error(late, truth) < 0.2 * raw
    off = truth + np.tile([0.3, -0.3, 0.0], 5)  # off the path's direction (1, 1, 1): no clock removes it
    assert dev.dtw_error(off, truth) == pytest.approx(0.3 * np.sqrt(2.0), rel=1e-9)


def test_half_time() -> None:
    disp = np.zeros((31, 3))
    disp[:, 0] = np.linspace(0.0, 3.0, 31)  # 0.1 m a frame
    assert dev.half_time(disp, np.array([3.0, 0.0, 0.0]), 10.0) == pytest.approx(1.5)
    assert np.isnan(dev.half_time(disp, np.array([10.0, 0.0, 0.0]), 10.0))  # never reached
    assert np.isnan(dev.half_time(disp, np.zeros(3), 10.0))


def test_handover_phases_follow_the_wrists_and_the_object() -> None:
    inst = next(iter(generate_dataset(0, SyntheticConfig(interactions=("hand_over",), instances_per_interaction=1))))
    assert inst.object is not None
    k = inst.key_joints()
    d_recv = np.nanmin(np.linalg.norm(k[:, 1, 1:3] - inst.object[:, None], axis=-1), axis=1)
    reach = float(np.quantile(d_recv, 0.3))
    ph = dev.handover_phases(inst, reach, 0.45)
    assert np.all(np.diff(ph) >= 0) and ph[0] == 0
    first = int(np.argmax(ph >= 1))
    assert d_recv[first] < reach and np.all(d_recv[:first] >= reach)  # the transfer starts at the first reach
    tighter = dev.handover_phases(inst, 0.5 * float(d_recv.min()), 0.45)  # never within reach: all approach
    assert np.all(tighter == 0)
    no_object = inst.replace(object=None)
    assert np.all(dev.handover_phases(no_object, reach, 0.45) == 0)
