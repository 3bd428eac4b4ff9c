"""``SynthesisConfig.overrun_delta_t``: once the running sub-event has overrun its predicted end, re-plan every ΔT
frames instead of at every frame (issue 24's real-time target; an option, off by default)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.data.interaction import Interaction
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.learning.estimator import SocialAffordanceModel

STREAM_FRAMES = 600  # two instances end to end, cycled: a stream of 48 s at 12.5 Hz, far past the belief's 4-s horizon


class _Plans(OnlineSynthesizer):
    """Records (t, last) of every re-planning's top branch (the one that sets the next re-planning)."""

    def __init__(self, *a, **k) -> None:  # noqa: ANN002, ANN003
        super().__init__(*a, **k)
        self.plans: list[tuple[int, int]] = []

    def _end_frame(self, s: int, start: int, t: int) -> int:
        last = super()._end_frame(s, start, t)
        if not self.plans or self.plans[-1][0] != t:
            self.plans.append((t, last))
        return last


def _stream(parts: list) -> Interaction:  # noqa: ANN001
    """``parts`` end to end, cycled, cut to :data:`STREAM_FRAMES` frames."""
    k = -(-STREAM_FRAMES // sum(p.n_frames for p in parts))
    cat = [p for _ in range(k) for p in parts]
    return parts[0].replace(joints=np.concatenate([p.joints for p in cat])[:STREAM_FRAMES],
                            valid=np.concatenate([np.ones(p.joints.shape[:3], bool) if p.valid is None else p.valid for p in cat])[:STREAM_FRAMES], subevents=None,
                            subevent_names=(), instance_id="stream")


def _plans(model: SocialAffordanceModel, inter: Interaction, config: SynthesisConfig) -> tuple[list[tuple[int, int, int]], int]:
    """(t, last, next re-planning frame) of every re-planning over ``inter``."""
    n = inter.n_frames
    syn = _Plans(model, None, config)
    syn.reset(observed_part(inter, config.n_observed), rng=np.random.default_rng(0))
    while not syn.done:
        syn.step()
    nxt = [p[0] for p in syn.plans[1:]] + [n]
    return [(t, last, k) for (t, last), k in zip(syn.plans, nxt, strict=True)], n


def test_overrun_delta_t_is_on_in_the_reactive_default_only() -> None:
    # Adopted in session 22 by its declared rule (docs/design.md §8): the default preset's synthesis has it; the
    # field's default, the paper's and the offline settings keep re-planning at every predicted end.
    assert SynthesisConfig.reactive().overrun_delta_t
    assert not SynthesisConfig().overrun_delta_t and not SynthesisConfig.paper().overrun_delta_t
    assert not SynthesisConfig.offline().overrun_delta_t


@pytest.mark.parametrize("on", [False, True], ids=["off", "on"])
def test_overrun_replans_every_delta_t_only_with_the_option(shake8_model: SocialAffordanceModel, shake8: Dataset, on: bool) -> None:
    """Past the belief's horizon the predicted end is the current frame: without the option the next re-planning is
    the next frame, with it ΔT frames later; a re-planning that has not overrun stops at its end either way."""
    cfg = SynthesisConfig.reactive(overrun_delta_t=on)
    plans, n = _plans(shake8_model, _stream([shake8[6], shake8[7]]), cfg)
    overrun = [(t, k) for t, last, k in plans if last == t]
    assert len(overrun) >= 20  # past the belief's horizon the running sub-event outlasts its duration model
    for t, last, k in plans:
        if last == t and on:
            assert k == min(t + cfg.delta_t, n)
        else:
            assert k == min(t + cfg.delta_t, last + 1, n)
    if on:
        assert all(k - t == cfg.delta_t for t, k in overrun[:-1])
    else:
        assert all(k - t == 1 for t, k in overrun[:-1])


def test_overrun_option_without_replan_at_end_changes_nothing(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Without ``replan_at_end`` every re-planning is ΔT apart already: the option leaves the synthesis bitwise equal."""
    out = []
    for on in (False, True):
        cfg = dataclasses.replace(SynthesisConfig(), overrun_delta_t=on)
        syn = OnlineSynthesizer(shake8_model, None, cfg)
        syn.reset(observed_part(shake8[6], cfg.n_observed), rng=np.random.default_rng(0))
        out.append(np.array([syn.step().key_joints for _ in range(shake8[6].n_frames)]))
    np.testing.assert_array_equal(out[0], out[1])
