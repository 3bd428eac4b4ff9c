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
in the package changes a learned array in place. :func:`per_model` makes the arrays of the value it builds read-only
(:func:`read_only`, every array reachable from the value, the model's own arrays excepted): a reader that wrote into
one would raise instead of changing another recording's set-up. Each caller is one call, its ``build`` the value only.

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

_SPARE = ("model_cache", "spare")  # the entry holding the ids of what the model reaches

_CACHE: weakref.WeakKeyDictionary[Any, dict[Hashable, tuple[tuple[Any, ...], Any]]] = weakref.WeakKeyDictionary()


def _token(model: Any) -> tuple[Any, ...]:
    """The objects a cached value of ``model`` depends on: its configuration and its learned attributes."""
    state = vars(model)
    return (model.__dict__.get("config"),) + tuple(v for k, v in state.items() if k.endswith("_") and not k.startswith("_"))


def _same(made: tuple[Any, ...], token: tuple[Any, ...]) -> bool:
    """Whether an entry made at ``made`` is still valid at ``token``: the very same objects, one by one."""
    return len(made) == len(token) and all(a is b for a, b in zip(made, token, strict=True))


def per_model(model: Any, key: Hashable, build: Callable[[], T]) -> T:
    """``build()``, made once per fitted ``model`` and ``key`` (what else the value depends on, e.g. the frame rate),
    and made anew when the model was refitted or reloaded since, its arrays made read-only (module docstring)."""
    token = _token(model)
    entries = _CACHE.get(model)
    if entries is None:
        entries = _CACHE[model] = {}
    hit = entries.get(key)
    if hit is not None and _same(hit[0], token):
        return hit[1]
    value = build()
    spare = entries.get(_SPARE)  # what the model reaches, walked once per model state (not once per value)
    if spare is None or not _same(spare[0], token):
        spare = entries[_SPARE] = (token, frozenset(id(x) for x in _reachable((model,), set())))
    _freeze((value,), spare[1])
    entries[key] = (token, value)
    return value


def read_only(*values: object, spare: object = None) -> None:
    """Make every ndarray reachable from ``values`` read-only: the arrays themselves, inside tuples, lists and dict
    values, and the attributes of objects (dataclasses, the type tables), each object visited once. Nothing reachable
    from ``spare`` (the model) is changed or entered: a value that holds the model's own array leaves it writable."""
    _freeze(values, frozenset(id(x) for x in _reachable((spare,), set())) if spare is not None else frozenset())


def _freeze(values: tuple[object, ...], kept: frozenset[int]) -> None:
    """Every ndarray reachable from ``values`` made read-only, objects whose id is in ``kept`` neither changed nor
    entered."""
    for a in _reachable(values, set(kept)):
        if isinstance(a, np.ndarray):
            a.setflags(write=False)


def _reachable(roots: tuple[object, ...], skip: set[int]) -> list[object]:
    """Every object reachable from ``roots`` through tuples, lists, dict values and object attributes (classes not
    entered), each once, those whose id is in ``skip`` excepted."""
    seen, out, stack = set(skip), [], list(roots)
    while stack:
        a = stack.pop()
        if id(a) in seen:
            continue
        seen.add(id(a))
        out.append(a)
        if isinstance(a, (tuple, list)):
            stack.extend(a)
        elif isinstance(a, dict):
            stack.extend(a.values())
        elif not isinstance(a, (np.ndarray, type)) and hasattr(a, "__dict__"):
            stack.extend(vars(a).values())
    return out
