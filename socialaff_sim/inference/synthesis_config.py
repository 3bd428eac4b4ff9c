"""Settings of the online synthesizer (Algorithm 2): the defaults, the paper's (:meth:`SynthesisConfig.paper`),
a reactive and an offline preset."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ConfigError, choices
from .compiled import KERNELS

__all__ = ["SynthesisConfig"]

_DURATION_MODES = ("sample", "median")
_INTERPOLATIONS = ("linear", "minjerk")
_PARSES = ("online", "observed")
_END_PRIORS = ("none", "regression")
_CONTACTS = ("none", "timed", "triggered")
_OPEN_INTERVALS = ("survival", "closed")
_BELIEFS = ("forward", "argmax")
_SELECTIONS = ("expected", "likelihood")


@dataclass(frozen=True)
class SynthesisConfig:
    """Settings of Algorithm 2; change them with ``dataclasses.replace``. :meth:`paper` is Algorithm 2 as
    the paper states it; the defaults differ from it in ``vertical_sign``, ``open_interval``, ``parse_window``,
``duration``, ``end_prior`` and the hedging fields ``belief``, ``branches`` and ``selection`` (docs/design.md).

    Fields by concept
    -----------------
    - Online schedule: n_observed, delta_t, replan_at_end, overrun_delta_t
    - Running sub-event and its end: parse, belief, belief_step, belief_horizon, ordered, parse_window,
      observed_parse_step, open_interval, duration, lookahead
    - Candidate end configurations: n_samples, spatial_fraction, coherent_fraction, refine_sweeps, vertical_sign,
      end_prior, prior_samples, selection
    - Hedging against wrong futures: branches, shrink
    - Motion toward the chosen end: interpolation, frame_weight, frame_decay
    - Contacts: contact, contact_width, trigger_scale
    - Handedness: hand_margin
    - Implementation: kernel
    """

    n_observed: int = 10
    """T0 [frames]: frames of both agents observed before synthesis starts."""
    delta_t: int = 5
    """ΔT [frames]: frames synthesized between two re-plannings."""
    n_samples: int = 100
    """N [—]: candidate key-joint configurations drawn per re-planning."""
    spatial_fraction: float = 0.5
    """[—]: Share of the N candidates drawn around the spatial references (the rest from the motion potential)."""
    duration: str = "median"
    """[—]: How the remaining duration is chosen: ``"sample"`` (the paper) or ``"median"`` of the conditional log-normal
    (the default: a drawn end is one more random commitment to a future; the median is the point estimate of least
    expected absolute error in time)."""
    coherent_fraction: float = 0.0
    """[—]: Share of the N candidates whose non-base joints each, with probability ½, keep their offset from agent 1's
    base (they move with the drawn base) instead of their own draw: body-coherent candidates, so the potentials of
    all joints inform the body's position (0: every joint drawn independently, as in the paper)."""
    refine_sweeps: int = 0
    """[—]: Sweeps of per-joint coordinate ascent over the drawn candidates; 0 keeps the best whole draw, as in the
    paper (on the synthetic data two sweeps tripled the cost without lowering the error)."""
    interpolation: str = "linear"
    """[—]: Time profile of the way from agent 1's last synthesized pose to the planned end configuration:
    ``"linear"`` (the paper) or ``"minjerk"``, the rest of the minimum-jerk profile 10v³ − 15v⁴ + 6v⁵ of the
    running sub-event (v = elapsed fraction from its anchor frame to its predicted end), the profile the
    model's path-noise term assumes."""
    lookahead: bool = False
    """[—]: Use agent 0's (and the object's) recorded position at the predicted end for the spatial
    references instead of the latest observed one (offline evaluation only; the simulator is causal)."""
    parse: str = "online"
    """[—]: How the running sub-event and its end are found: ``"online"`` (the paper), a DP over the frames
    so far and a duration drawn from the log-normal prior; or ``"observed"``, one DP over agent 0's
    (and the object's) whole recorded track before synthesis starts
    (:func:`~socialaff_sim.inference.observed_parse.parse_observed`; offline only, needs ``lookahead``)."""
    parse_window: float | None = 4.5
    """W [s]: the ``"online"`` parse reads the last W to 1.5 W seconds only (its start moves in hops of W / 2; its
    atoms, its DP, a uniform label prior at the window's start once frame 0 has left it), and keeps the scores
    of intervals and the DP rows already computed, so a re-planning costs the same after an hour as after a
    second (:class:`~socialaff_sim.inference.stream_parse.StreamParser`). Instances shorter than 1.5 W (6.75 s:
    every recording of the shared sets, at most 6.7 s) are parsed exactly as with None: every frame since the
    start, as in the paper, whose cost grows with the time elapsed. Smaller is faster (docs/benchmarks.md)."""
    belief: str = "forward"
    """[—]: How the ``"online"`` synthesis finds the running sub-event: ``"forward"`` (our change), the filtering
    posterior over (sub-event, elapsed duration) summed over every parse on a grid of cut points
    (:class:`~socialaff_sim.inference.forward_belief.ForwardBelief`; O(1) work and memory per frame in the time
    elapsed), updated every frame and exposed as the step's belief; or ``"argmax"`` (the paper), the best parse
    of the DP over atom cut points (:class:`~socialaff_sim.inference.stream_parse.StreamParser`), at re-plannings."""
    belief_step: float = 0.2
    """[s]: Distance between the cut points of the ``"forward"`` belief, rounded to whole frames (at least one):
    2 frames at 12.3 Hz, 3 at 15 Hz, 6 at 30 Hz. Its work per second of stream is then the same at every frame rate."""
    belief_horizon: float = 4.0
    """[s]: Longest sub-event the ``"forward"`` belief tracks exactly; older starts share one bucket, treated as
    begun this long ago (bounds its work and memory per frame)."""
    ordered: bool = False
    """[—]: With the ``"forward"`` belief, the plan follows the sub-events' learned order: a re-planning chooses among
    the sub-events whose rank (mean position in the model's training parses, :func:`~socialaff_sim.model.transitions.order_ranks`)
    is not below that of the sub-event planned so far, by their posterior restricted to them; if none of them has
    any mass, the planned sub-event runs on from its start (overrunning). Once the planned sub-event began
    ``belief_horizon`` ago or more, any sub-event may follow (the filter forgets the labels used before its horizon, so
    a stream of repeated interactions can start the sequence again). The belief the step exposes is the forward
    filter's, unchanged; the step's ``subevent`` is the planned one. On the handovers' development split the filter's
    arg-max returns below a sub-event it has reached on 9 % of the frames, where Algorithm 2's plan errs by 0.92 m
    (0.32 m with this option, which lowered the handovers' development error from 0.2376 to 0.2204 m but raised the
    synthetic set's from 0.1314 to 0.1429 m, failing its declared rule: docs/design.md §8, "What the sub-events
    carry"). False (the default, and the paper): the posterior's most probable sub-events, whatever came before."""
    branches: int = 1
    """[—]: With the ``"forward"`` belief: the most probable sub-events (at most this many, each with belief ≥ 0.1)
    planned at every re-planning; the frames emitted are their plans' belief-weighted mean. 1 (the default): the most
    probable sub-event only, from its most probable start (2 was 0.0005 m worse on the synthetic set's fold 1 and
    raised NuiSI's full-skeleton error on the waves from 0.076 to 0.136 m: the mean of two plans is a pose neither
    plans; docs/design.md)."""
    selection: str = "expected"
    """[—]: Which of the candidate end configurations is kept: ``"likelihood"`` (the paper), the most likely; or
    ``"expected"``, the one of least expected squared error when the truth is distributed over the candidates
    with weights ∝ exp(score / 5), i.e. the candidate nearest that weighted mean of agent 1's key joints. The
    potentials score every joint as independent evidence, which makes the raw weights overconfident (one
    candidate takes nearly all the weight); dividing by agent 1's five key joints was fixed a priori, not tuned."""
    shrink: float = 0.0
    """[—]: Shrinkage toward ``hold`` (agent 1's last observed pose) when the belief is uncertain: the emitted frames
    are hold + α (plan − hold) with α = 1 − shrink · H(belief) / log |S| (H the entropy; α = 1 for a certain
    belief). 0: no shrinkage (the paper, and the default: shrink = 1, fixed a priori, raised the causal error on the
    synthetic set's fold 1 from 0.143 to 0.277 m, where agent 1 walks and holding still costs 0.57 m; docs/design.md)."""
    observed_parse_step: int = 2
    """[frames]: Frames between the cut points of the ``"observed"`` parse."""
    end_prior: str = "regression"
    """[—]: ``"regression"`` (the default): also score candidates by the model's end-configuration regression, a
    Gaussian over agent 1's five key joints jointly (:mod:`~socialaff_sim.model.end_regression`), conditioned on
    agent 0's (and the object's) latest observed pose causally, and draw ``prior_samples`` more candidates from it;
    ``"none"``: the paper's potentials alone."""
    prior_samples: int = 50
    """[—]: Candidates drawn from the end-configuration regression, on top of the N, when ``end_prior`` is on."""
    frame_weight: float = 0.0
    """[—]: Share of the model's frame regression (agent 1 at each frame from agent 0 at that frame,
    :mod:`~socialaff_sim.model.frame_regression`) in every synthesized frame, the rest being the
    interpolation toward the planned end; 0: the interpolation alone, as in the paper."""
    replan_at_end: bool = False
    """[—]: Also re-plan at the predicted end of the running sub-event when that comes before the next ΔT
    boundary, so the next sub-event's first frames head for its own end instead of holding this one's
    end configuration. False: every ΔT frames, as in the paper."""
    overrun_delta_t: bool = False
    """[—]: With ``replan_at_end``: a re-planning whose running sub-event has overrun (its predicted last frame is the
    current frame t: the sub-event has lasted as long as its duration model expects, or longer) plans the next ΔT
    frames instead of one, so the next re-planning is ΔT frames later (on by :meth:`reactive`, the default preset's
    synthesis, since session 22: its declared rule held, docs/design.md §8). Whether a sub-event whose start is the
    ``"forward"`` belief's long bucket (treated as begun ``belief_horizon`` ago) has overrun is decided by its duration
    model like any other's: only when that age lies more than about 7.03 σ above the log-normal's median (the
    conditional median is taken at a quantile clamped to 1 − 10⁻¹²,
    :func:`~socialaff_sim.inference.timing.sample_remaining_seconds`); otherwise its predicted end is a few frames
    ahead, at every re-planning. False (the field's default, and the paper's): re-plan after every predicted end, i.e.
    at every frame while the sub-event overruns (on a long handover stream 94 % of the frames re-plan)."""
    contact: str = "none"
    """[—]: Pull of agent 1's wrist toward its contact keyframes (the model's ``contact_keys_``): toward the
    touched joint plus the learned offset, with a Gaussian weight that is 1 at the keyframe.
    ``"timed"`` (needs ``lookahead``): around the keyframe's phase in the running sub-event, σ =
    ``contact_width`` frames, agent 0 read at the frame itself. ``"triggered"`` (causal): while the
    touched joint, at the latest observed frame, is near where it was at the touches in training
    relative to agent 0's base (σ = ``trigger_scale`` × the keyframe's spread); the online parse's clock
    is too uncertain to time a touch of two or three frames. ``"none"``: no pull, as in the paper."""
    contact_width: float = 1.5
    """σ [frames]: width of the ``"timed"`` pull around the keyframe's phase."""
    trigger_scale: float = 1.5
    """[keyframe spread]: σ of the ``"triggered"`` pull in units of the keyframe's spread: above 1 the robot's hand starts
    toward the person's before it reaches its contact pose (a touch lasts two or three frames, and the
    pose is read one frame late)."""
    frame_decay: float = 5.0
    """[frames]: Frames over which the frame regression's offset from the last emitted pose fades (it starts where
    the synthesized track is, so the track stays continuous)."""
    vertical_sign: bool = True
    """[—]: Our addition: the potentials score |dz| only, so candidates draw the sign of dz with the learned
    frequency of dz > 0 (``vertical_up_``) and are also scored by it. False (the paper): signs drawn
    with probability ½, no sign term."""
    open_interval: str = "survival"
    """[—]: How the online parse scores the still-running last sub-event: ``"survival"`` (our change), by the
    probability that its duration exceeds the time elapsed, its end not yet reached; ``"closed"``
    (the paper's DP over the frames so far), like every other interval, as if it ended at the latest
    frame (potentials at that frame and the duration density of the elapsed time)."""
    hand_margin: float = 0.2
    """[m]: causal synthesis with a model whose ``config.active_hand`` is on: agent 0 counts as
    left-active only once its left wrist's path so far exceeds its right's by this much (right-active
    until then). Early frames are walking, whose arm swing moves both wrists alike; on the synthetic
    data 0.2 m never commits to the wrong side. With ``lookahead`` the whole track decides, margin 0,
    as in training."""
    kernel: str = "numpy"
    """[—]: How the reactor's kernels are evaluated: ``"numpy"`` (the default and the reference) or ``"numba"``,
    compiled loops (:mod:`~.compiled`; the optional extra ``[fast]``), equal to NumPy's within the tolerance
    declared in docs/design.md §7, not bitwise."""

    def __post_init__(self) -> None:
        if self.n_observed < 2:
            raise ConfigError(f"n_observed (T0): expected at least 2 frames, found {self.n_observed}")
        if self.delta_t < 1:
            raise ConfigError(f"delta_t (ΔT): expected at least 1 frame, found {self.delta_t}")
        if self.n_samples < 1:
            raise ConfigError(f"n_samples (N): expected at least 1, found {self.n_samples}")
        if not 0.0 <= self.coherent_fraction <= 1.0:
            raise ConfigError(f"coherent_fraction: expected a value in [0, 1], found {self.coherent_fraction}")
        if not 0.0 <= self.spatial_fraction <= 1.0:
            raise ConfigError(f"spatial_fraction: expected a value in [0, 1], found {self.spatial_fraction}")
        if self.interpolation not in _INTERPOLATIONS:
            raise ConfigError(f"interpolation: expected {choices(_INTERPOLATIONS)}, found {self.interpolation!r}")
        if self.parse not in _PARSES:
            raise ConfigError(f"parse: expected {choices(_PARSES)}, found {self.parse!r}")
        if self.parse == "observed" and not self.lookahead:
            raise ConfigError("parse='observed' reads agent 0's recorded future: it needs lookahead=True (offline evaluation)")
        if self.end_prior not in _END_PRIORS:
            raise ConfigError(f"end_prior: expected {choices(_END_PRIORS)}, found {self.end_prior!r}")
        if not 0.0 <= self.frame_weight <= 1.0:
            raise ConfigError(f"frame_weight: expected a value in [0, 1], found {self.frame_weight}")
        if not self.hand_margin >= 0:
            raise ConfigError(f"hand_margin: expected metres >= 0, found {self.hand_margin}")
        if not self.contact_width > 0:
            raise ConfigError(f"contact_width: expected a number of frames > 0, found {self.contact_width}")
        if not self.trigger_scale > 0:
            raise ConfigError(f"trigger_scale: expected a number > 0, found {self.trigger_scale}")
        if self.contact not in _CONTACTS:
            raise ConfigError(f"contact: expected {choices(_CONTACTS)}, found {self.contact!r}")
        if self.contact == "timed" and not self.lookahead:
            raise ConfigError("contact='timed' reads agent 0 at the keyframe's frame: it needs lookahead=True (offline); use 'triggered' causally")
        if not self.frame_decay > 0:
            raise ConfigError(f"frame_decay: expected a number of frames > 0, found {self.frame_decay}")
        if self.observed_parse_step < 1 or self.prior_samples < 0:
            raise ConfigError(
                f"observed_parse_step, prior_samples: expected >= 1 and >= 0, found {self.observed_parse_step}, {self.prior_samples}"
            )
        if self.open_interval not in _OPEN_INTERVALS:
            raise ConfigError(f"open_interval: expected {choices(_OPEN_INTERVALS)}, found {self.open_interval!r}")
        if self.parse_window is not None and not self.parse_window > 0:
            raise ConfigError(f"parse_window (W): expected seconds > 0 or None, found {self.parse_window}")
        if self.belief not in _BELIEFS:
            raise ConfigError(f"belief: expected {choices(_BELIEFS)}, found {self.belief!r}")
        if self.selection not in _SELECTIONS:
            raise ConfigError(f"selection: expected {choices(_SELECTIONS)}, found {self.selection!r}")
        if self.branches < 1:
            raise ConfigError(f"branches: expected at least 1, found {self.branches}")
        if not self.belief_step > 0:
            raise ConfigError(f"belief_step: expected seconds > 0, found {self.belief_step}")
        if not self.belief_horizon > 0:
            raise ConfigError(f"belief_horizon: expected seconds > 0, found {self.belief_horizon}")
        if not 0.0 <= self.shrink <= 1.0:
            raise ConfigError(f"shrink: expected a value in [0, 1], found {self.shrink}")
        if self.kernel not in KERNELS:
            raise ConfigError(f"kernel: expected {choices(KERNELS)}, found {self.kernel!r}")
        if self.duration not in _DURATION_MODES:
            raise ConfigError(f"duration: expected {choices(_DURATION_MODES)}, found {self.duration!r}")

    @classmethod
    def paper(cls, **changes: object) -> SynthesisConfig:
        """Algorithm 2 as the paper states it: after T0 = 10 observed frames, every ΔT = 5 frames a DP over
        all the frames so far (no window; the running sub-event scored as if it ended now), a duration drawn from the
        conditional log-normal, N = 100 candidates from the potentials (signs of dz at random), the most
        likely kept, linear interpolation; causal (no lookahead), no regression, no contact pull."""
        base: dict[str, object] = dict(
            n_observed=10, delta_t=5, n_samples=100, duration="sample", interpolation="linear", lookahead=False,
            parse="online", end_prior="none", frame_weight=0.0, replan_at_end=False, contact="none",
            coherent_fraction=0.0, refine_sweeps=0, vertical_sign=False, open_interval="closed", parse_window=None,
            belief="argmax", selection="likelihood", shrink=0.0, branches=1,
        )
        return cls(**{**base, **changes})  # type: ignore[arg-type]

    @classmethod
    def reactive(cls, **changes: object) -> SynthesisConfig:
        """Causal settings for a robot reacting to a person (the simulator's and the environment's
        default): the default Algorithm 2 plus an equal share of the frame regression, which reads
        agent 0, and the phase, at the latest observed frame, a re-planning at each predicted sub-event end, and the
        pull toward contact keyframes triggered by agent 0's touching joint reaching its contact pose; an overrun
        sub-event is re-planned every ΔT frames (``overrun_delta_t``), and re-plannings follow the sub-events' learned
        order (``ordered``; both adopted by development-split rules, docs/design.md §8)."""
        return cls(**{"frame_weight": 0.5, "replan_at_end": True, "overrun_delta_t": True, "ordered": True,
                      "contact": "triggered", **changes})  # type: ignore[arg-type]

    @classmethod
    def offline(cls, **changes: object) -> SynthesisConfig:
        """The settings for an offline evaluation, where agent 0's whole track is given (as to every
        method of the protocol): lookahead, the ``"observed"`` parse, the end-configuration regression,
        minimum-jerk interpolation, the frame regression, a re-planning at each sub-event end and the pull
        toward contact keyframes.
        ``SynthesisConfig.paper()`` is the paper's causal Algorithm 2."""
        base = dict(
            lookahead=True, parse="observed", end_prior="regression", interpolation="minjerk", frame_weight=0.5,
            replan_at_end=True, contact="timed", duration="sample", selection="likelihood", shrink=0.0,
        )
        return cls(**{**base, **changes})  # type: ignore[arg-type]
