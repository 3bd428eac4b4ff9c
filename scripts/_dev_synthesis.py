"""Synthesis settings on the development split (issue 24; docs/design.md §7, "Cheaper causal synthesis settings"), for
scripts/dev_switching.py: ``--set FIELD=VALUE`` changes a field of the default preset's causal synthesis
(``SynthesisConfig.reactive()``) for every trace of the run, training and validation (what the default would compute
with it), and names the traces' cache apart; the fitted affordance models (Algorithm 1 and the body clusters, which
read no synthesis setting) are cached once per class, rotation and seed with the generator's state after the fit, so
that each setting's run starts from the same fitted models and generator state as a run without the cache would.
The library never imports this module.
"""

from __future__ import annotations

import argparse
import pickle
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from socialaff_sim.data import Interaction
from socialaff_sim.inference.methods import AffordanceMethod

from _reactor_args import add_setting_argument, changed_synthesis  # scripts/ (sys.path[0])


def add_synthesis_arguments(ap: argparse.ArgumentParser) -> None:
    """``--set FIELD=VALUE`` (repeatable) for the default preset's causal synthesis."""
    add_setting_argument(ap, "the default preset's causal synthesis (every trace, training and validation; cached apart)")


def with_settings(method: AffordanceMethod, settings: Sequence[str], ap: argparse.ArgumentParser) -> AffordanceMethod:
    """``method`` with its causal synthesis changed by ``settings`` (``FIELD=VALUE``; a malformed one: exit 2)."""
    if settings:
        method.synthesis = changed_synthesis(method.synthesis, list(settings), ap)  # type: ignore[assignment]
    return method


def settings_suffix(settings: Sequence[str]) -> str:
    """The traces' cache-name suffix of ``settings`` ('' without any): ``_set-belief_step-0.4`` …"""
    return "".join("_set-" + s.replace("=", "-") for s in settings)


def fit_cached(method: AffordanceMethod, train: Sequence[Interaction], rng: np.random.Generator,
               path: Path | None) -> float:
    """Fit ``method`` (``reaction=None``: the affordance models and the body clusters) on ``train`` with ``rng``,
    or read that fit and ``rng``'s state after it from ``path`` (written after a fit); the fit's seconds (nan when
    read). The fit reads no synthesis setting, so runs that differ only in ``--set`` share it."""
    if path is not None and path.exists():
        models, body, state = pickle.loads(path.read_bytes())
        method.models_, method.model_, method.body_ = models, models[0], body
        rng.bit_generator.state = state
        return float("nan")
    t0 = time.perf_counter()
    method.fit(list(train), rng=rng)
    seconds = time.perf_counter() - t0
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(pickle.dumps((method.models_, method.body_, rng.bit_generator.state)))
    return seconds
