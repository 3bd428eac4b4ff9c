"""What the causal reactor's set-up reads of a fitted model only, made once per model instead of once per recording
(issue 24, real-time speed: the recordings' first frames).

Every recording the reactor starts on builds an :class:`~.synthesis.OnlineSynthesizer` (and its
:class:`~.forward_belief.ForwardBelief`), whose set-up stacked the model's potentials
(:class:`~.type_tables.TypeTables`, twice), tabulated the duration survival, ranked the types and, at the first
re-planning, made every type's draw and score terms: about a quarter of a recording's first call on the handovers,
all of it a function of the fitted model (and of fixed settings) only. :func:`per_model` keeps such a value per model
object, keyed by what it depends on besides the model, and makes it anew when the model changes: a value is valid while
the model's configuration and every learned attribute (a name ending in ``_``) are the very objects they were when it
was made. :meth:`~socialaff_sim.learning.estimator.SocialAffordanceModel.fit` and ``load`` assign new objects; nothing
in the package changes a learned array in place. The cached arrays are made read-only (:func:`read_only`): a reader
that wrote into one would raise instead of changing another recording's set-up.

The values are the same objects every time, so their arithmetic is the same: the reactor's outputs are bitwise those
of the per-recording set-up (tests/test_reactor_setup.py).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

import numpy as np

__all__ = ["per_model", "read_only"]

T = TypeVar("T")

_CACHE: weakref.WeakKeyDictionary[Any, dict[Hashable, tuple[tuple[Any, ...], Any]]] = weakref.WeakKeyDictionary()


def _token(model: Any) -> tuple[Any, ...]:
    """The objects a cached value of ``model`` depends on: its configuration and its learned attributes."""
    state = vars(model)
    return (model.__dict__.get("config"),) + tuple(v for k, v in state.items() if k.endswith("_") and not k.startswith("_"))


def per_model(model: Any, key: Hashable, build: Callable[[], T]) -> T:
    """``build()``, made once per fitted ``model`` and ``key`` (what else the value depends on, e.g. the frame rate),
    and made anew when the model was refitted or reloaded since (module docstring)."""
    token = _token(model)
    entries = _CACHE.get(model)
    if entries is None:
        entries = _CACHE[model] = {}
    hit = entries.get(key)
    if hit is not None and len(hit[0]) == len(token) and all(a is b for a, b in zip(hit[0], token, strict=True)):
        return hit[1]
    value = build()
    entries[key] = (token, value)
    return value


def read_only(*arrays: object) -> None:
    """Make every ndarray among ``arrays`` (and inside tuples, lists and dict values of them) read-only."""
    for a in arrays:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
        elif isinstance(a, (tuple, list)):
            read_only(*a)
        elif isinstance(a, dict):
            read_only(*a.values())
