"""scripts/_dev_draws.py: the default regression per draw of its inner folds, against the library fitted on the k-th
partition directly, and the averaged blend never worse than the mean of the draws on any instance (the error is
convex in the prediction)."""

from __future__ import annotations

import numpy as np

from conftest import load_script
from test_switching_repeats import T0, _config, _single, _toy

from socialaff_sim.inference.switching import SwitchingRegression, instance_rows

dev_draws = load_script("_dev_draws")


def test_partition_draws_match_the_library_and_jensen() -> None:
    insts, traces = _toy(3)
    train, val, tr_traces, va_traces = insts[:7], insts[7:] + insts[:2], traces[:7], traces[7:] + traces[:2]
    rows = [instance_rows(i, t, T0, _config().features) for i, t in zip(val, va_traces, strict=True)]

    def score(reg: SwitchingRegression) -> list[float]:
        return [float(np.linalg.norm((reg.displacement(X, O, P) - Y).reshape(len(Y), -1, 3), axis=-1).mean())
                for X, Y, O, P in rows]

    first = score(_single(train, tr_traces, 3, 0))
    per, took = dev_draws.partition_draws(_config(), train, tr_traces, 2, 3, 3, first, score)
    for k in (1, 2):
        assert per[f"sw:default@{k}"] == score(_single(train, tr_traces, 3, k))
    np.testing.assert_allclose(per["sw:default@mean"], np.mean([per[f"sw:default@{k}"] for k in range(3)], axis=0))
    assert np.all(np.asarray(per["sw:default_bag3"]) <= np.asarray(per["sw:default@mean"]) + 1e-12)
    assert "bag3" in took
