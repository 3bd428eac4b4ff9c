"""Online synthesis of agent 1's motion in reaction to agent 0 (Algorithm 2 of the paper).

After ``T0`` observed frames of both agents, every ``ΔT`` frames the synthesizer

1. finds the running sub-event: with ``belief="forward"`` (the default) from the filtering posterior over
   (sub-event, elapsed duration) of the frames so far (:class:`~socialaff_sim.inference.forward_belief.ForwardBelief`,
   updated every frame, O(1) work and memory per frame), planning for its most probable sub-events (at most
   ``branches``, :func:`~socialaff_sim.inference.hedging.branch_plans`) from their most probable starts; with
   ``belief="argmax"`` (the paper) from the best parse of a DP over the track so far, the last sub-event still
   running (:class:`~socialaff_sim.inference.stream_parse.StreamParser`);
2. takes the remaining duration of each planned sub-event from its log-normal prior conditioned on the time
   already elapsed (drawn, as the paper, or its median), which fixes the predicted end frame;
3. draws ``N`` candidate configurations of agent 1's key joints at that end — half around the
   spatial reference of each affordable joint (its group's mass centre, or the other agent's base),
   half by a displacement from the sub-event's start drawn from the motion potential; Null joints
   keep their offset from agent 1's base (they are static relative to the body); optionally a share
   of them body-coherent (``coherent_fraction``) — and keeps the most likely under the spatial and
   motion potentials (``selection="likelihood"``, the paper) or the one of least expected error under
   the candidates' tempered scores (``"expected"``, the default);
   With ``end_prior="regression"`` the model's end-configuration regression adds draws and a joint
   Gaussian term over agent 1's five key joints (:class:`~socialaff_sim.inference.candidates.RegressionPrior`);
4. interpolates agent 1's key joints from its last synthesized position to that configuration,
   linearly (the paper) or along the rest of a minimum-jerk profile (``interpolation``), and emits
   the next ``ΔT`` frames: the belief-weighted mean of the planned sub-events' paths, shrunk toward
   ``hold`` (agent 1's last observed pose) by the belief's entropy (``shrink``); a full-body skeleton is
   fitted to them (:class:`~socialaff_sim.inference.body_fit.BodyFitter`).

The belief of every step (:attr:`SynthesisStep.belief`) is what the simulator and the environment read.

It runs one frame at a time (:meth:`OnlineSynthesizer.step`); fed a growing view
(:meth:`OnlineSynthesizer.observe`, a stream) it reads only the view's new frames
(:class:`~socialaff_sim.inference.canonical_stream.CanonicalStream`), so its work per frame does not grow with
the time elapsed; under a causal configuration it holds only the last frames its readers read
(:class:`~socialaff_sim.inference.track_window.TrackWindow`, :attr:`OnlineSynthesizer.window`), so neither does its
memory. It reads agent 0 and the object
causally: at frame t only frames before t are used, unless ``lookahead`` is set, in which case the
spatial references use agent 0's recorded position at the predicted end (the setting of an offline
evaluation where agent 0's whole track is given, as it is to the baselines); there ``parse="observed"``
replaces steps 1–2 by one parse of agent 0's whole track (:meth:`SynthesisConfig.offline` sets all of it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..data.interaction import Interaction
from ..errors import ModelError
from ..model.handedness import KEY_SWAP, relabel
from ..model.transitions import order_ranks
from . import compiled
from .candidate_planner import CandidatePlanner
from .canonical_stream import CanonicalStream
from .candidates import AGENT1 as _AGENT1
from .forward_belief import ForwardBelief
from .hedging import branch_plans, shrink_factor
from .model_cache import per_model
from .type_tables import TypeTables
from .observed import ObservedInteraction
from .observed_parse import parse_observed
from .path_planner import PathPlanner
from .stream_parse import ParseWork, StreamParser
from .synthesis_config import SynthesisConfig
from .synthesis_step import SynthesisStep
from .working_track import OTHERS as _OTHERS, WorkingTrack, reader_window
from .timing import remaining_fraction, sample_remaining_seconds

if TYPE_CHECKING:
    from ..learning.estimator import SocialAffordanceModel
    from .body_fit import BodyFitter

__all__ = ["SynthesisConfig", "SynthesisStep", "OnlineSynthesizer", "sample_remaining_seconds", "remaining_fraction"]



class OnlineSynthesizer(CandidatePlanner, PathPlanner):
    """Agent 1's key joints (and skeleton), frame by frame, from a fitted affordance model."""

    def __init__(
        self, model: SocialAffordanceModel, body: BodyFitter | None = None, config: SynthesisConfig | None = None
    ) -> None:
        model._check()
        self.model = model
        self.body = body
        self.config = config or SynthesisConfig()
        self._inter: Interaction | None = None
        self._parser: StreamParser | None = None
        # The potentials of every type stacked once per fitted model: the candidates' scores without per-call set-up.
        # kernel="numba" (issue 24, session 27): the tables' densities and the candidates' scores compiled; a missing
        # extra is named here, not at the first re-planning.
        compiled.require(self.config.kernel)
        self._tables = TypeTables.of(model, self.config.kernel) if model.config.vector_density == "polar" else None

    # -- episode -----------------------------------------------------------------------------------
    def reset(self, interaction: Interaction, *, rng: np.random.Generator, n_frames: int | None = None) -> None:
        """Start on an instance: agent 0 and the object are read causally, agent 1's first T0 frames observed.
        ``n_frames``: the working track's length, the instance lengthened by held frames
        (:meth:`~socialaff_sim.data.interaction.Interaction.extend_held`; a stream's first view)."""
        cfg = self.config
        # Canonicalised once; agent 1 hidden after T0.
        obs = ObservedInteraction.of(interaction.extend_held(n_frames or 0), cfg.n_observed)
        if interaction.label != self.model.label_:
            raise ModelError(
                f"instance {interaction.instance_id!r} is a {interaction.label!r} interaction but the model learned "
                f"{self.model.label_!r}: choose a {self.model.label_!r} instance, or fit a {interaction.label!r} "
                f"model (socialaff-sim fit --interaction {interaction.label})"
            )
        self._inter = interaction
        self._rng = rng
        # Agent 1's observed skeletons, gap-filled once per instance rather than once per observed frame.
        self._observed_skeleton = (
            interaction.filled_joints()[: cfg.n_observed, 1] if self.body is not None else None
        )
        self._frame = obs.frame
        # The model joints as recorded and agent 0's wrist paths, updated with each view's new frames only.
        self._view = CanonicalStream(obs.frame)
        if cfg.n_observed >= 1:
            self._view.pin(cfg.n_observed - 1)
        self._view.update(interaction, obs.n_frames)
        # Agent 0 and the object stay in the track over the whole instance (read beyond t - 1 with lookahead only).
        self._track = WorkingTrack.of(obs.track, "the synthesizer's working track")
        if cfg.n_observed >= 1:
            self._track.pin(cfg.n_observed - 1)  # the hold frame T0 - 1: the planner's reference, read at every re-planning
        self._parser = None
        if cfg.parse == "online":
            lc = self.model.learning
            window = None if cfg.parse_window is None else max(int(round(cfg.parse_window * interaction.fps)), 2)
            self._parser = StreamParser(
                self.model, interaction.fps, window,
                min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds,
                open_interval=cfg.open_interval,
            )
        self._filter: ForwardBelief | None = None
        if cfg.parse == "online" and cfg.belief == "forward":
            stride = max(int(round(cfg.belief_step * interaction.fps)), 1)
            horizon = max(int(round(cfg.belief_horizon * interaction.fps)), stride)
            self._filter = ForwardBelief(self.model, interaction.fps, stride=stride, horizon=horizon, kernel=cfg.kernel)
            self._parser = None  # the forward belief replaces the DP parse
        self._keep = reader_window(cfg, self._filter, self._parser)
        self._stale = False
        self._hands = np.zeros(2, bool)
        self._set_hands(cfg.n_observed)
        self._t = 0
        self._planned_until = cfg.n_observed
        self._span = (0, 0)  # (first, last frame) of the running sub-event at the latest re-planning
        self._sub = -1  # the running sub-event of the latest re-planning
        # With ``ordered``: each type's mean position in the training parses (NaN: never used, always allowed).
        self._ranks = self._order_ranks() if cfg.ordered else None
        self._available = self.model.available_.copy()
        self._refw: dict[int, np.ndarray] = {}
        S = self.model.n_subevents_
        self._belief = np.full(S, 1.0 / S)
        self._rows: np.ndarray | None = None
        if cfg.parse == "observed":
            self._rows = parse_observed(self.model, self._observed_track(), interaction.fps, step=cfg.observed_parse_step)

    def _order_ranks(self) -> np.ndarray:
        """(S,) :func:`~socialaff_sim.model.transitions.order_ranks` of the model's training parses, read-only, made
        once per fitted model (:func:`~.model_cache.per_model`)."""
        model = self.model
        return per_model(model, "order_ranks", lambda: order_ranks(model.parses_, model.n_subevents_))

    def observe(self, view: Interaction, n_frames: int | None = None) -> None:
        """Stream mode: agent 0's and the object's new frames from ``view``, the instance as known now, lengthened
        to ``n_frames`` frames by held ones (default: the view's length); agent 1's frames are kept. Views grow: the
        frames of earlier views are unchanged (the evaluation's protocols feed them so). Work per call: the new and
        held frames, and a tracking gap that closes (:class:`~.canonical_stream.CanonicalStream`)."""
        if self._inter is None:
            raise ModelError("OnlineSynthesizer.observe called before reset(interaction, rng=...)")
        T = max(view.n_frames if n_frames is None else int(n_frames), view.n_frames)
        if T < self._t:
            raise ModelError(f"observe: the view has {T} frames, but {self._t} were emitted already")
        floor = 0 if self._keep is None else max(self._t - self._keep, 0)  # frames before it are read no more
        changed = self._view.update(view, T, keep_from=floor)
        self._track.forget(floor)
        if self._track.take(self._view, changed, T, self._hands, self._t):  # the parser's scores or the belief are stale
            self._history_changed()
        self._inter = view

    @property
    def window(self) -> int | None:
        """L: frames before the next frame that the synthesizer still holds at least (None: every frame)."""
        return self._keep

    def _set_hands(self, t: int) -> None:
        """Relabel the working tracks by the active-hand flags known at frame ``t`` (agent 0's whole track
        with ``lookahead``, else its frames before ``t`` and ``hand_margin``); a flag that changes relabels
        the history too, so emitted frames keep their recorded labels and the track stays continuous."""
        cfg = self.config
        if cfg.lookahead:  # no window: every frame held
            hands = self.model.reaction_hands(np.asarray(self._view.track), None, 0.0)
        else:  # agent 0's wrist paths so far, from running sums: O(1) per re-planning on a stream of any length
            hands = self.model.reaction_hands_at(self._view.paths, t, cfg.hand_margin)
        change = hands != self._hands
        if change.any():  # the frames held and the pinned hold frame: the older ones are read no more
            self._track.map(lambda x: relabel(x, change))
            self._hands = hands
            self._history_changed()

    def _history_changed(self) -> None:
        """Frames already parsed changed: the parse's cached scores and the forward belief are stale."""
        if self._parser is not None:
            self._parser.reset()
        self._stale = True

    def _advance_belief(self, t: int) -> None:
        """The forward belief over frames [0, t) (replayed over its last 2 horizons after a history change:
        bounded work), and the step's belief from it."""
        fb = self._filter
        assert fb is not None  # internal invariant: belief == "forward"
        if self._stale:
            origin = 0 if t <= 2 * fb.horizon else ((t - fb.horizon) // fb.stride) * fb.stride
            fb.reset(origin)
            self._stale = False
        fb.advance(self._track, t)
        self._belief = fb.belief(t)

    def _observed_track(self) -> np.ndarray:
        """(T, 11, 3) canonical: agent 0 and the object over the whole instance, agent 1 NaN."""
        track = np.asarray(self._track)  # every frame: the observed parse holds no window
        x = np.full_like(track, np.nan)
        x[:, _OTHERS] = track[:, _OTHERS]
        return x

    @property
    def work(self) -> ParseWork | None:
        """What the latest online parse did (counts; None without one): bounded by the window, not by t."""
        return None if self._parser is None else self._parser.work

    @property
    def belief_rows(self) -> int | None:
        """Start rows the forward belief holds now (bounded by its horizon, not by t); None without one."""
        return None if self._filter is None else self._filter.memory

    @property
    def t(self) -> int:
        """The next frame :meth:`step` will emit."""
        return self._t

    @property
    def done(self) -> bool:
        """Whether every frame of the instance has been emitted."""
        return self._inter is not None and self._t >= self._track.shape[0]

    def step(self) -> SynthesisStep:
        """Emit the next frame."""
        if self._inter is None:
            raise ModelError("OnlineSynthesizer.step called before reset(interaction, rng=...)")
        if self.done:
            raise ModelError(f"instance {self._inter.instance_id!r} has no frame {self._t}: synthesis is finished")
        t = self._t
        cfg = self.config
        observed = t < cfg.n_observed
        if self._filter is not None and t >= 1:
            self._advance_belief(t)
        if not observed and t >= self._planned_until:
            self._replan(t)
        if not observed and cfg.contact != "none":
            self._pull_contacts(t)
        keys_c = self._track[t, _AGENT1]
        if self._hands[1]:
            keys_c = keys_c[KEY_SWAP]  # back to the recorded labels
        keys_w = self._frame.to_world(keys_c)
        skeleton = None
        if self.body is not None:
            if observed:
                skeleton = self._observed_skeleton[t]  # type: ignore[index]
            else:
                skeleton = self.body.fit_pose(keys_c, self._frame) if np.isfinite(keys_c[0]).all() else None
        sub = -1 if observed else self._sub
        first, last = self._span
        phase = float("nan") if observed else min(max((t - first) / max(last - first + 1, 1), 0.0), 1.0)
        self._t += 1
        return SynthesisStep(
            t=t,
            key_joints=keys_w,
            skeleton=skeleton,
            belief=self._belief.copy(),
            subevent=sub,
            subevent_name=None if sub < 0 else self.model.subevent_names_[sub],
            observed=observed,
            phase=phase,
        )

    # -- planning ----------------------------------------------------------------------------------
    def _replan(self, t: int) -> None:
        if not self.config.lookahead:  # with lookahead the flags were fixed at reset
            self._set_hands(t)
        if self._filter is not None:
            plans = branch_plans(*self._filter.posterior(t), self.config.branches, self._allowed(t))
            if not plans:  # ordered, and nothing at or after the planned sub-event is possible: it runs on
                plans = [(1.0, self._sub, self._span[0])]
        else:
            s, start = self._current(t)
            plans = [(1.0, s, start)]
        paths, stop = [], None
        for k, (w, s, start) in enumerate(plans):
            last = self._end_frame(s, start, t)
            if k == 0:
                self._sub, self._span = s, (start, last)
            target = self._best_configuration(s, t, start, last)
            path, stop_k = self._path(t, s, start, last, target, stop)
            stop = stop_k if stop is None else stop
            paths.append(w * path)
        # np.sum over one plan's path is 0.0 + that path (its reduction starts from 0: −0.0 becomes 0.0): one addition
        path = paths[0] + 0.0 if len(paths) == 1 else np.sum(paths, axis=0)
        if self.config.shrink > 0:
            hold = self._track[self.config.n_observed - 1, _AGENT1]
            alpha = shrink_factor(self._belief, self.config.shrink)
            path = np.where(np.isfinite(hold)[None], hold[None] + alpha * (path - hold[None]), path)
        assert stop is not None  # at least one plan
        self._track[t:stop, _AGENT1] = path
        self._planned_until = stop

    def _allowed(self, t: int) -> np.ndarray | None:
        """(S,) bool: the sub-events a re-planning at frame t may choose (``ordered``: not ranked before the planned
        one), or None (any: not ordered, nothing planned yet, or the planned one began a belief horizon ago or more,
        beyond which the forward belief forgets the labels used, so that a stream can start the sequence again)."""
        fb = self._filter
        if self._ranks is None or self._sub < 0 or not np.isfinite(self._ranks[self._sub]):
            return None
        if fb is not None and t - self._span[0] >= fb.horizon:
            return None
        return ~(self._ranks < self._ranks[self._sub])  # NaN ranks compare False: allowed

    def _current(self, t: int) -> tuple[int, int]:
        """The running sub-event and its first frame, from the online parse of frames [0, t)."""
        if self._rows is not None:
            row = self._row(t)
            S = self.model.n_subevents_
            self._belief = np.eye(S)[row[2]]
            return int(row[2]), int(row[0])
        assert self._parser is not None  # internal invariant: set by reset for parse == "online"
        parse, _ = self._parser.parse(self._track.rows, t, self._available, offset=self._track.floor)
        self._belief = parse.belief
        return parse.current, parse.start

    def _end_frame(self, s: int, start: int, t: int) -> int:
        """The predicted last frame (≥ t) of the running sub-event ``s`` begun at ``start`` (t itself: overrun)."""
        if self._rows is not None:
            return max(int(self._row(t)[1]) - 1, t)
        inter = self._inter
        assert inter is not None  # internal invariant: set by reset
        mu, sigma = self.model.duration_params_[s]
        total = sample_remaining_seconds(
            mu, sigma, (t - start) / inter.fps, self._rng, median=self.config.duration == "median"
        )
        return max(start + int(round(total * inter.fps)), t + 1) - 1

    def _row(self, t: int) -> np.ndarray:
        """The observed parse's interval (start, stop, label) holding frame ``t``."""
        assert self._rows is not None  # internal invariant: parse == "observed"
        k = int(np.searchsorted(self._rows[:, 1], t, side="right"))
        return self._rows[min(k, len(self._rows) - 1)]
