"""The path step of Algorithm 2: agent 1's key joints over the next frames, on the way to the chosen end
configuration, and the contact pull of each emitted frame.

:class:`PathPlanner` is mixed into :class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer` and reads its episode
state (``model``, ``config``, the canonical working track ``_track``, the joints ``_available``, the running
sub-event ``_sub`` and its span ``_span``); subclasses (the tests) override :meth:`PathPlanner._path` and
:meth:`PathPlanner._pull_contacts` to watch them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..data.skeletons import N_KEY
from ..model.contact_keys import Keyframe
from ..model.frame_regression import frame_context
from ..model.nan_fill import nan_to_zero
from ..model.ridge import RidgeRegression
from .candidates import AGENT1 as _AGENT1
from .synthesis_config import SynthesisConfig
from .timing import remaining_fraction
from .working_track import OTHERS as _OTHERS

if TYPE_CHECKING:
    from ..model.affordance import AffordanceParameters
    from .working_track import WorkingTrack

__all__ = ["PathPlanner"]


class PathPlanner:
    """Interpolate toward the end configuration, blend the frame regression, pull toward contacts (a mixin of the
    online synthesizer)."""

    model: AffordanceParameters
    config: SynthesisConfig
    _track: WorkingTrack
    _available: np.ndarray
    _sub: int
    _span: tuple[int, int]

    def _keyframes(self, s: int | None) -> list[Keyframe]:
        """The model's contact keyframes of type ``s`` (None: of every type), made once per model: the keyframes are
        fixed by the fit, and the triggered pull reads every one of them at every frame. Every list is made at the
        first call, so that the synthesizer's state does not change size later in a stream."""
        keys = self.model.contact_keys_
        cache = self.__dict__.get("_keyframe_lists")
        if cache is None or cache[0] is not keys:
            lists: dict[int | None, list[Keyframe]] = {k: keys.of_type(k) for k in range(self.model.n_subevents_)}
            lists[None] = keys.all()
            cache = self._keyframe_lists = (keys, lists)
        return cache[1][s]

    def _pull_contacts(self, t: int) -> None:
        """Blend agent 1's wrists at frame t toward their contact keyframes (touched joint + learned offset)
        with weight exp(−½ d²): d = (t − t*) / σ around the keyframe's phase t* in the running sub-event
        (``"timed"``), or the distance of the touched joint from its contact pose relative to agent 0's
        base over ``trigger_scale`` × the keyframe's spread, at frame t − 1 (``"triggered"``)."""
        cfg = self.config
        timed = cfg.contact == "timed"
        keyframes = self._keyframes(self._sub if timed else None)
        if not keyframes:  # nothing to pull (the same frame as the loop below over no keyframe)
            return
        start, last = self._span
        x0 = self._track[t if timed else t - 1]
        for key in keyframes:
            if timed:
                d = (t - (start + key.phase * (last - start))) / cfg.contact_width
            else:
                d = float(np.linalg.norm(x0[key.mate] - x0[0] - key.pose)) / (cfg.trigger_scale * key.spread)
            goal = x0[key.mate] + key.offset
            if abs(d) > 3.0 or not (np.isfinite(d) and np.isfinite(goal).all() and np.isfinite(self._track[t, key.joint]).all()):
                continue
            self._track[t, key.joint] += np.exp(-0.5 * d * d) * (goal - self._track[t, key.joint])

    def _path(
        self, t: int, s: int, start: int, last: int, target: np.ndarray, stop: int | None = None
    ) -> tuple[np.ndarray, int]:
        """Agent 1's key joints (F, 5, 3) for frames [t, stop) on the way from frame t − 1 to ``target`` at ``last``
        (blended with the frame regression of sub-event ``s`` begun at ``start`` when ``frame_weight`` > 0), and
        stop: t + ΔT (up to ``last`` with ``replan_at_end``, unless the sub-event overran with ``overrun_delta_t``)
        unless given."""
        cfg = self.config
        if stop is None:
            stop = min(t + cfg.delta_t, self._track.shape[0])
            if cfg.replan_at_end and not (cfg.overrun_delta_t and last <= t):
                stop = min(stop, last + 1)  # last >= t: at least one frame
        prev = self._track[t - 1, _AGENT1]
        frames = np.arange(t, stop)
        if cfg.interpolation == "minjerk":
            w = remaining_fraction(frames, t - 1, max(start - 1, 0), last)
        else:
            w = ((frames - (t - 1)) / max(last - (t - 1), 1)).clip(0.0, 1.0)
        path = prev[None] + w[:, None, None] * (target - prev)[None]
        reg = self.model.frame_regression_[s] if cfg.frame_weight > 0 else None
        if reg is not None:
            path = (1.0 - cfg.frame_weight) * path + cfg.frame_weight * self._frame_prediction(reg, t, stop, start, last, prev)
        return path, stop

    def _frame_prediction(
        self, reg: RidgeRegression, t: int, stop: int, start: int, last: int, prev: np.ndarray
    ) -> np.ndarray:
        """(F, 5, 3) canonical: the frame regression over frames [t, stop), shifted to start at ``prev``
        (agent 1 at t − 1) with the shift fading over ``frame_decay`` frames. Agent 0 is read at each
        frame with ``lookahead``; else agent 0 and the phase are both those of frame t − 1, the latest
        observed, so the track heads from ``prev`` toward where the regression puts agent 1 now."""
        cfg = self.config
        frames = np.arange(t - 1, stop)
        seen = frames if cfg.lookahead else np.minimum(frames, t - 1)
        config = np.empty((frames.size, 2 * N_KEY + 1, 3))
        config[:, _OTHERS] = self._track[seen[:, None], _OTHERS]
        # The phase goes with agent 0's frame: the regression learnt them in pairs, and a phase run on
        # ahead of a person held still asks for a pose it never saw.
        phase = ((seen - start + 1) / max(last - start + 1, 1)).clip(0.0, 1.0)
        # The regressions' reference frame: agent 1's last observed pose (frame T0 − 1).
        ref = np.repeat(self._track[self.config.n_observed - 1][None], frames.size, axis=0)
        ctx = frame_context(config, ref, phase, self._available)
        pred = reg.predict(ctx).reshape(-1, N_KEY, 3) + config[:, 0:1]
        fade = np.exp(-(frames[1:] - (t - 1)) / cfg.frame_decay)[:, None, None]
        out = pred[1:] + fade * (nan_to_zero(prev) - pred[0])[None]
        return np.where(np.isfinite(prev)[None], out, np.nan)
