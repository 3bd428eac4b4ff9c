""":func:`~socialaff_sim.inference.model_cache.per_model` makes the values it caches read-only itself (issue 24, session
26): every array reachable from the value (inside tuples, lists, dicts, dataclasses and objects) is frozen, the
model's own arrays never are, even when the value holds one. The four callers (the type tables, the forward belief's
constants, the candidate planner's type plans, the ranks of the types) are each one call: their cached arrays are
read-only, the model's stay writable, and a refit makes them anew (tests/test_reactor_setup.py holds the values
against the per-recording set-up, bitwise)."""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import pytest

from socialaff_sim.inference import model_cache
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.type_tables import TypeTables


@dataclass(frozen=True)
class _Plan:
    a: np.ndarray
    nested: tuple


class _Holder:
    def __init__(self) -> None:
        self.x = np.zeros(3)
        self.d = {"k": [np.ones(2), (np.arange(4),)]}
        self.me = self  # a cycle: visited once


def _arrays(value: object) -> list[np.ndarray]:
    return [a for a in model_cache._reachable((value,), set()) if isinstance(a, np.ndarray)]


def test_per_model_freezes_every_array_of_the_value_but_the_models(shake8_model) -> None:  # noqa: ANN001
    model = copy.copy(shake8_model)
    own = model.spatial_params_
    value = per = model_cache.per_model(
        model, "freeze", lambda: (_Plan(np.ones(2), ([np.zeros(1)], {"h": _Holder()})), own, own[0], [np.eye(2)])
    )
    arrays = _arrays(value)
    assert len(arrays) == 8  # the plan's two, the holder's three, the model's array and its view, the list's
    for a in arrays:
        if a is own:
            assert a.flags.writeable  # the model's own array: never frozen
        else:
            assert not a.flags.writeable, a
    assert own.flags.writeable and own[0] is not per[2]
    with pytest.raises(ValueError):
        per[0].a[0] = 2.0
    own[0, 0, 0] = own[0, 0, 0]  # still writable in place


def test_read_only_spares_what_the_model_reaches_and_nothing_else() -> None:
    class Model:
        pass

    m = Model()
    m.w_ = np.zeros(2)
    m.nested_ = [np.ones(2)]
    other = np.ones(3)
    model_cache.read_only((m.w_, m.nested_[0], other), spare=m)
    assert m.w_.flags.writeable and m.nested_[0].flags.writeable and not other.flags.writeable
    free = np.ones(2)
    model_cache.read_only(free)  # no model to spare: frozen
    assert not free.flags.writeable


def test_the_four_sites_cache_read_only_values(shake8_model) -> None:  # noqa: ANN001
    model = copy.copy(shake8_model)
    tables = TypeTables.of(model)
    fb = ForwardBelief(model, 30.0, stride=6, horizon=120)
    syn = OnlineSynthesizer(model, None, SynthesisConfig(ordered=True))
    syn._refw, syn._available = {}, model.available_.copy()
    syn._type_plan(0)
    plans = syn._plans[1]  # every type's plan, made at the first look-up
    ranks = syn._order_ranks()
    constants = (fb._trans, fb._bits, fb._surv, fb._path_use, fb._path_c, fb._path_2s2, fb._into, fb._from, fb._dur, fb._short)
    for value in (tables, constants, plans, ranks):
        arrays = _arrays(value)
        assert arrays and not any(a.flags.writeable for a in arrays)
    assert len(plans) == model.n_subevents_ and all(not p.z.flags.writeable for p in plans.values())
    for name in ("spatial_params_", "motion_params_", "duration_params_", "grouping_", "available_", "vertical_up_",
                 "log_transitions_", "path_sigma_"):
        assert getattr(model, name).flags.writeable, name
    model.grouping_ = model.grouping_.copy()  # a refit: every site makes its value anew
    syn2 = OnlineSynthesizer(model, None, SynthesisConfig(ordered=True))
    syn2._refw, syn2._available = {}, model.available_.copy()
    assert TypeTables.of(model) is not tables and syn2._order_ranks() is not ranks
    assert syn2._type_plan(0) is not plans[0]
    assert ForwardBelief(model, 30.0, stride=6, horizon=120)._surv is not fb._surv


def test_the_model_is_walked_once_per_state(shake8_model, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    """What the model reaches is walked once for every value of one model state, and again after a refit."""
    model = copy.copy(shake8_model)
    walked: list[int] = []
    reach = model_cache._reachable
    monkeypatch.setattr(model_cache, "_reachable", lambda roots, skip: walked.append(roots[0] is model) or reach(roots, skip))
    for k in range(3):
        model_cache.per_model(model, ("walk", k), lambda: np.zeros(2))
    assert sum(walked) == 1  # the model once; each value once
    model.motion_params_ = model.motion_params_.copy()  # a refit
    assert not model_cache.per_model(model, ("walk", 0), lambda: [model.motion_params_])[0] is None
    assert sum(walked) == 2 and model.motion_params_.flags.writeable  # walked anew: the new array is the model's
