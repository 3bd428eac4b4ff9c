"""The end of a running sub-event whose start is the forward belief's long bucket (issue 24's re-planning cadence on
streams): its duration model's conditional median given the age ``belief_horizon``, and the 7.03-σ clamp past which it
overruns (``SynthesisConfig.overrun_delta_t``'s docstring). The option ``horizon_overrun``, which counted every such
sub-event as overrun, was removed; these were its tests' "off" cases."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.timing import sample_remaining_seconds
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.learning.estimator import SocialAffordanceModel

from test_overrun_replan import _stream


def _conditional_median(mu: float, sigma: float, elapsed: float) -> float:
    """Median [s] of LogNormal(μ, σ) given D > elapsed, from scipy.stats (the reference)."""
    d = stats.lognorm(s=sigma, scale=np.exp(mu))
    return float(d.isf(d.sf(elapsed) / 2.0))


@pytest.mark.parametrize("z", [5.0, 6.5, 6.9, 7.2, 8.0])
def test_the_long_bucket_overruns_only_past_the_clamp(z: float) -> None:
    # What overrun_delta_t's docstring now says: an age z σ above the median overruns (the elapsed time comes back)
    # only past Φ⁻¹(1 − 10⁻¹²) ≈ 7.03 σ; below it the end is scipy's conditional median, after the elapsed time.
    mu, sigma = np.log(0.96), 0.22
    elapsed = float(np.exp(mu + z * sigma))
    got = sample_remaining_seconds(mu, sigma, elapsed, np.random.default_rng(0), median=True)
    threshold = float(stats.norm.isf(1e-12))
    assert 7.0 < threshold < 7.1
    if z > threshold:
        assert got == elapsed
    else:
        assert got > elapsed
        assert got == pytest.approx(_conditional_median(mu, sigma, elapsed), rel=1e-6)


def _synthesizer(model: SocialAffordanceModel, shake8: Dataset) -> OnlineSynthesizer:
    cfg = SynthesisConfig.reactive()
    syn = OnlineSynthesizer(model, None, cfg)
    syn.reset(observed_part(shake8[6], cfg.n_observed), rng=np.random.default_rng(0))
    return syn


def test_end_frame_of_the_long_bucket(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """A start ``belief_horizon`` or more before t, and one frame younger: the end is the duration model's conditional
    median (scipy) given the age, after t."""
    model = copy.deepcopy(shake8_model)
    model.duration_params_ = model.duration_params_.copy()
    model.duration_params_[0] = (np.log(3.0), 0.5)  # 4 s is 0.58 σ above the median: the end is well after t
    syn = _synthesizer(model, shake8)
    fb, fps, t = syn._filter, shake8[6].fps, 200
    assert fb is not None and round(4.0 * fps) <= fb.horizon < t  # a whole number of cuts
    for age in (fb.horizon - 1, fb.horizon, fb.horizon + 7):
        start = t - age
        expected = start + int(round(_conditional_median(np.log(3.0), 0.5, age / fps) * fps)) - 1
        assert expected > t
        assert syn._end_frame(0, start, t) == expected


class _Plans(OnlineSynthesizer):
    """Records (t, start, last) of every re-planning's top branch."""

    def __init__(self, *a, **k) -> None:  # noqa: ANN002, ANN003
        super().__init__(*a, **k)
        self.plans: list[tuple[int, int, int]] = []

    def _end_frame(self, s: int, start: int, t: int) -> int:
        last = super()._end_frame(s, start, t)
        if not self.plans or self.plans[-1][0] != t:
            self.plans.append((t, start, last))
        return last


def test_long_bucket_plans_end_at_the_predicted_end(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """On a 48-s stream, each re-planning in the long bucket predicts an end after t, and the next re-planning comes
    at that end or ΔT frames later, whichever is first."""
    model = copy.deepcopy(shake8_model)
    model.duration_params_ = model.duration_params_.copy()
    model.duration_params_[:, 0] = np.log(3.0)  # every sub-event long enough to end after a 4-s age
    model.duration_params_[:, 1] = 0.5
    inter = _stream([shake8[6], shake8[7]])
    cfg = SynthesisConfig.reactive()
    syn = _Plans(model, None, cfg)
    syn.reset(observed_part(inter, cfg.n_observed), rng=np.random.default_rng(0))
    while not syn.done:
        syn.step()
    assert syn._filter is not None
    H, n = syn._filter.horizon, inter.n_frames
    nxt = [p[0] for p in syn.plans[1:]] + [n]
    old = [(t, last, k) for (t, start, last), k in zip(syn.plans, nxt, strict=True) if t - start >= H]
    assert len(old) >= 10  # the stream runs far past the horizon
    for t, last, k in old:
        assert last > t and k == min(t + cfg.delta_t, last + 1, n)
