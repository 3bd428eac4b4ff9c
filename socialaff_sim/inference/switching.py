"""The full model's reaction: a switching regression gated by the affordance model's sub-event belief.

The synthesizer (:class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer`) runs as before and
gives, for every output frame t, its causal belief b_t (S,) over the running sub-event (the forward
filter's, from agent 0's and the object's frames before t), the elapsed fraction φ_t of the running
sub-event (from its start and predicted end), and its plan: agent 1's key joints synthesized by
Algorithm 2. Agent 1's pose at t is then agent 1's last observed pose plus a displacement of its whole
skeleton, in the anchor frame of :mod:`.reaction_features`, that is linear in

``agent0``, ``gap``, ``own_velocity``, ``agent0_velocity`` (49)
    the causal motion features of :mod:`.reaction_features` (those of the ``ridge`` baseline);
``subevent`` (S)
    b_t,s · r(s): a learned displacement per sub-event type, mixed by the belief, ramped from zero
    (r(s) = 1 − e^{−s/τ}, s seconds since agent 1's last observed frame);
``phase`` (S)
    b_t,s · φ_t · r(s): how that displacement grows as the sub-event runs (the phase of a ProMP, here the
    affordance model's);
``gated`` (S × the motion columns chosen)
    b_t,s · x_t: one linear map of the motion features per sub-event type, mixed by the belief — a mixture
    of linear experts gated by the model's causal sub-event belief, Σ_s b_t,s W_s x_t;
``plan`` (15)
    the plan's displacement of agent 1's key joints from their last observed position (anchor frame);
``from_plan`` (no columns)
    the prior: with it the displacement is the plan's (its whole skeleton, fitted to the planned key joints
    by the model's body fitter) plus the linear term, which the ridge penalty then shrinks toward the plan
    instead of toward ``hold``; alone, it is Algorithm 2's synthesis itself;
``primitive`` (15), ``from_primitive`` (no columns)
    the same two for a phase-based prediction: an interaction primitive
    (:class:`~.interaction_primitive.InteractionPrimitive`, the ``promp`` baseline's model) of the class,
    conditioned on agent 0's frames ≤ t, its phase from the duration estimated on them.

The candidates come in *families* (:attr:`SwitchingConfig.families`): ``motion`` (the motion groups alone:
the ``ridge`` baseline's candidates), ``subevent`` (motion groups with the belief-gated groups) and ``plan``
(the plan as prior or features, with or without the gated groups) and ``primitive`` (the interaction
primitive's prediction as prior or features). An inner cross-validation on the training
instances (:mod:`.reaction_regression`) picks each family's best (groups, λ), then the weights α_f ≥ 0,
Σα_f ≤ 1 (a grid of step 0.1; the rest on ``hold``) of the blend Σ_f α_f prediction_f that minimise the
held-out error of the families' held-out predictions; ties go to more ``hold``. A part of the affordance
model is thus used only as far as it lowered the held-out error on the training data, and averaging the
families' predictions (instead of keeping one winner) damps the selection noise of small training sets.
The same configuration (:class:`SwitchingConfig`) serves every dataset. The training rows' plans and primitive
predictions are cross-fitted (``SwitchingConfig.cross_fit``: out of sample, as at test); their beliefs and phases
come from the model fitted on all training instances (in sample: slightly optimistic about the belief-gated groups).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, NotFittedError
from .interaction_primitive import ProMPConfig
from .protocol import DEFAULT_N_OBSERVED
from .reaction_features import FEATURE_GROUPS, FeatureConfig
from .reaction_regression import (
    HOLD, blend_weights, cv_errors, fold_predictions, inner_folds, key_columns, ridge_solve, select, stack_instances,
)
from .switching_rows import (
    Trace, instance_rows, plan_displacement, plan_offset, switching_columns, switching_rows, switching_scale,
)

__all__ = [
    "FAMILIES", "GATED_FAMILIES", "HOLD", "MODEL_GROUPS", "PRIMITIVE_FAMILIES", "PRIORS", "Member", "SwitchingConfig", "SwitchingRegression", "Trace", "instance_rows", "plan_displacement",
    "plan_offset", "switching_columns", "switching_rows", "switching_scale",
]

MODEL_GROUPS: tuple[str, ...] = ("subevent", "phase", "gated", "plan", "from_plan", "primitive", "from_primitive")
"""The groups driven by a model of the class (columns in this order after the motion features, but for the
priors ``from_plan`` and ``from_primitive``); all but the last two are the affordance model's."""

PRIORS: tuple[str, ...] = ("from_plan", "from_primitive")
"""The groups that are a prior (the prediction the ridge term is added to); a candidate holds at most one."""


def _motion_subsets() -> tuple[tuple[str, ...], ...]:
    return tuple(c for r in range(1, len(FEATURE_GROUPS) + 1) for c in itertools.combinations(FEATURE_GROUPS, r))


Family = tuple[str, tuple[tuple[str, ...], ...]]

FAMILIES: tuple[Family, ...] = (("motion", ((),)), ("plan", (("from_plan",), ("plan",))))
"""The motion features alone (``ridge``'s candidates), and the plan as prior or features: the default before the
primitive's family (registered as the method ``full_noprimitive``)."""

GATED_FAMILIES: tuple[Family, ...] = (
    ("motion", ((),)),
    ("subevent", (("subevent",), ("subevent", "phase"), ("subevent", "phase", "gated"))),
    ("plan", (("from_plan",), ("plan",), ("from_plan", "subevent", "phase"), ("from_plan", "subevent", "phase", "gated"))),
)
"""With the belief-gated groups as well (tried on the development split and left out of the default: docs/design.md)."""

PRIMITIVE_FAMILIES: tuple[Family, ...] = FAMILIES + (("primitive", (("from_primitive",), ("primitive",))),)
"""The default families: :data:`FAMILIES` and the interaction primitive's prediction as prior or features
(docs/design.md §8)."""


@dataclass(frozen=True)
class SwitchingConfig:
    """Settings of the switching regression, fixed before any evaluation (the inner CV chooses among its candidates).

    Each candidate is a set of motion groups joined with a set of model-driven groups; the candidates come in
    families, whose best members are blended."""

    features: FeatureConfig = field(default_factory=FeatureConfig)
    """[—]: How the motion features are computed (as ``ridge``'s)."""
    motion: tuple[tuple[str, ...], ...] = field(default_factory=_motion_subsets)
    """[—]: Sets of motion groups (:data:`~.reaction_features.FEATURE_GROUPS`) the inner CV chooses among."""
    families: tuple[Family, ...] = PRIMITIVE_FAMILIES
    """[—]: (name, sets of model-driven groups) per family: each set (of :data:`MODEL_GROUPS`) is joined to each
    motion set (and, when not empty, also used without motion features); ``()`` is the motion features alone
    (the ``ridge`` baseline's candidates). Each family's best candidate enters the blend."""
    blend_steps: int = 10
    """[—]: The blend's weights are multiples of 1 / blend_steps (1: keep the single best family or ``hold``)."""
    cross_fit: int = 2
    """[—]: The plans (and the interaction primitive's predictions) of the training rows come from models fitted on
    the other parts of a split of the training instances into this many parts (pair-disjoint where possible): out
    of sample, as at test. 1: from the model
    fitted on all of them, in sample, which the inner CV then over-trusts (NuiSI's development split, docs/design.md).
    The beliefs and phases always come from the model fitted on all of them (its sub-event labels are the test's)."""
    cross_fit_type_passes: int | None = 0
    """[—]: ``LearningConfig.init_type_passes`` of the cross-fitted models only (Algorithm 1's type-level restructuring
    passes; 0: none, the default since its development-split rule held); None: the method's own, as for the model
    fitted on all instances. Fewer passes make the fit cheaper and change the cross-fitted plans (issue 24;
    docs/design.md §8, "Cheaper cross-fitted models")."""
    row_stride: int = 2
    """k [frames]: The training rows are frames T0, T0 + k, T0 + 2k, … of each training instance (each instance's
    rows still weigh one in all). 2: the default since its development-split rule held (session 22); 1: every
    frame ≥ T0, as before. The synthesizer still steps every frame (its
    state is sequential) and the interaction primitive's stream still reads every frame; what is skipped on the
    other frames is the primitive's prediction, the body fits of the plan and of the primitive, and the rows of
    the inner CV and the refit (issue 24: a cheaper fit; a model change, docs/design.md §8, "Two cheaper-fit
    options for the handovers"). Prediction is unchanged: every frame."""
    clip_features: bool = True
    """[—]: At prediction, clip each scaled column to the range it had in the training rows (widened by
    ``clip_margin``; the default since its development-split rule held), so that a
    feature far outside them (a test plan, from the model fitted on all instances, moving a joint that the
    cross-fitted training plans hardly moved) cannot extrapolate a member linearly (docs/design.md §8, "Clipped
    features")."""
    clip_margin: float = 1.0
    """m [—]: With ``clip_features``, the range [min, max] of the training rows is widened on each side by m times
    its width (0: the bare range, which failed its development rule on the synthetic set)."""
    penalties: tuple[float, ...] = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0)
    """λ [—]: Ridge penalties the inner CV chooses among (unit-RMS features, rows weighing one per instance)."""
    inner_folds: int = 3
    """[—]: Folds of the inner cross-validation on the training instances."""
    contiguous: bool = False
    """[—]: With a single actor pair, the inner folds and the cross-fitting's parts are consecutive runs of the
    training instances in their order (time order for one recording: held-out blocks of the session) instead of
    random instances (:func:`~.reaction_regression.inner_folds`); with two pairs or more they are pair-disjoint."""
    n_observed: int = DEFAULT_N_OBSERVED
    """T0 [frames]: agent 1's observed frames when the training rows are built (the evaluation's T0)."""
    fallback: tuple[tuple[str, ...], float] = (FEATURE_GROUPS + ("subevent",), 10.0)
    """[—]: (groups, λ) used when the training set has a single instance (no inner CV is possible)."""
    primitive: ProMPConfig = field(default_factory=ProMPConfig)
    """[—]: The interaction primitive of the ``primitive`` and ``from_primitive`` groups (its ``body_fit`` unused:
    the primitive's key joints are fitted by the affordance method's body fitter)."""

    def __post_init__(self) -> None:
        if not self.penalties or not all(p > 0 and math.isfinite(p) for p in self.penalties):
            raise ConfigError(f"penalties: expected finite values > 0, found {self.penalties}")
        bad = {g for c in self.motion for g in c} - set(FEATURE_GROUPS)
        if bad or not self.motion or not all(self.motion):
            raise ConfigError(f"motion: expected non-empty sets of {FEATURE_GROUPS}, found unknown {sorted(bad)}")
        bad = {g for _, extras in self.families for c in extras for g in c} - set(MODEL_GROUPS)
        if bad or not self.families or not all(extras for _, extras in self.families):
            raise ConfigError(f"families: expected non-empty lists of sets of {MODEL_GROUPS}, found unknown {sorted(bad)}")
        if any(len(set(c) & set(PRIORS)) > 1 for _, extras in self.families for c in extras):
            raise ConfigError(f"families: a set holds at most one of the priors {PRIORS}")
        if self.cross_fit < 1:
            raise ConfigError(f"cross_fit: expected at least 1, found {self.cross_fit}")
        if self.cross_fit_type_passes is not None and self.cross_fit_type_passes < 0:
            raise ConfigError(f"cross_fit_type_passes: expected None or at least 0, found {self.cross_fit_type_passes}")
        if isinstance(self.row_stride, bool) or not isinstance(self.row_stride, int) or self.row_stride < 1:
            raise ConfigError(f"row_stride: expected an integer >= 1, found {self.row_stride!r}")
        if not (self.clip_margin >= 0 and math.isfinite(self.clip_margin)):
            raise ConfigError(f"clip_margin: expected a finite number >= 0, found {self.clip_margin}")
        if self.blend_steps < 1:
            raise ConfigError(f"blend_steps: expected at least 1, found {self.blend_steps}")
        if self.inner_folds < 2:
            raise ConfigError(f"inner_folds: expected at least 2, found {self.inner_folds}")
        if self.n_observed < 1:
            raise ConfigError(f"n_observed: expected at least 1, found {self.n_observed}")

    @property
    def needs_belief(self) -> bool:
        """Whether a candidate reads the belief or the phase (``subevent``, ``phase``, ``gated``)."""
        return any(g in ("subevent", "phase", "gated") for _, extras in self.families for c in extras for g in c)

    @property
    def needs_primitive(self) -> bool:
        """Whether a candidate reads the interaction primitive (``primitive``, ``from_primitive``)."""
        return any(g in ("primitive", "from_primitive") for _, extras in self.families for c in extras for g in c)

    def candidates(self, family: str) -> tuple[tuple[str, ...], ...]:
        """The candidates' groups of ``family``: each motion set joined with each of its sets of model-driven
        groups, and each non-empty such set alone."""
        extras = dict(self.families)[family]
        return tuple(m + e for e in extras for m in ((),) * bool(e) + self.motion)


@dataclass(frozen=True, eq=False)
class Member:
    """One family's fitted candidate in the blend."""

    family: str
    """The family's name."""
    groups: tuple[str, ...]
    """Its groups (``from_plan`` or ``from_primitive`` in them: that prediction is its prior)."""
    penalty: float
    """λ (``inf``: no regression term)."""
    weight: float
    """α, its share of the blend."""
    columns: np.ndarray
    """(F_m,) int64 columns of :func:`switching_rows` it reads."""
    coefficients: np.ndarray
    """(F_m, J·3) its ridge weights on those (scaled) columns."""

    @property
    def prior(self) -> str | None:
        """Its prior (one of :data:`PRIORS`), or ``None`` (``hold``)."""
        return _prior_of(self.groups)

    @property
    def from_plan(self) -> bool:
        """Whether the plan is its prior."""
        return self.prior == "from_plan"


def _prior_of(groups: Sequence[str]) -> str | None:
    return next((g for g in groups if g in PRIORS), None)


class SwitchingRegression:
    """The switching regression (module docstring). Learned attributes: ``n_subevents_`` (S), ``members_``
    (the families' fitted candidates with weight α > 0; empty: ``hold``), ``cv_errors_`` ({(groups, λ): mean
    held-out key-joint error, m}), ``blend_error_`` (the blend's held-out error, m), ``scale_`` (the columns'
    RMS), ``lower_``/``upper_`` (each scaled column's range over the training rows, widened by ``clip_margin``)."""

    def __init__(self, config: SwitchingConfig | None = None) -> None:
        self.config = config or SwitchingConfig()

    def fit(
        self, interactions: Sequence[Interaction], traces: Sequence[Trace], *, n_subevents: int, rng: np.random.Generator
    ) -> SwitchingRegression:
        """Choose each family's groups and λ, and the blend's weights, by inner CV on ``interactions`` (one class;
        ``traces`` their synthesizer traces), then refit the members on all of them."""
        cfg = self.config
        if len(traces) != len(interactions):
            raise ModelError(f"switching regression: {len(interactions)} interactions but {len(traces)} traces")
        (X, Y, plan_prior, prim_prior), w, row_ids = stack_instances(
            interactions, cfg.n_observed,
            lambda i, inst: instance_rows(inst, traces[i], cfg.n_observed, cfg.features, stride=cfg.row_stride),
            "switching regression")
        S = self.n_subevents_ = int(n_subevents)
        self.scale_ = switching_scale(X, w, S)
        Xs = X / self.scale_
        seen = Xs[w > 0] if np.any(w > 0) else Xs
        low, high = seen.min(axis=0), seen.max(axis=0)
        margin = cfg.clip_margin * (high - low)
        self.lower_, self.upper_ = low - margin, high + margin
        folds = inner_folds(interactions, np.unique(row_ids), cfg.inner_folds, rng, contiguous=cfg.contiguous)
        priors = {"from_plan": plan_prior, "from_primitive": prim_prior}
        self.cv_errors_: dict[tuple[tuple[str, ...], float], float] = {}
        chosen: list[tuple[str, tuple[str, ...], float, float]] = []  # (family, groups, λ, α)
        if len(folds) >= 2:
            kc = key_columns(interactions[0])
            Yk = Y[:, kc]
            winners, preds = [], []
            for family, _ in cfg.families:
                candidates = {g: switching_columns(g, S) for g in cfg.candidates(family)}
                cv: dict[tuple[tuple[str, ...], float], float] = {}
                for prior in (None,) + PRIORS:  # one call per prior: cv_errors shifts by one offset
                    some = {g: c for g, c in candidates.items() if _prior_of(g) == prior}
                    if some:
                        cv.update(cv_errors(Xs, Yk, w, row_ids, folds, some, cfg.penalties,
                                            offset=priors[prior][:, kc] if prior else None, from_offset=some if prior else ()))
                self.cv_errors_.update(cv)
                groups, lam = select({k: v for k, v in cv.items() if k[0] != HOLD})
                winners.append((family, groups, lam))
                prior = _prior_of(groups)
                base = priors[prior][:, kc] if prior else np.zeros_like(Yk)
                preds.append(fold_predictions(Xs, Yk, w, row_ids, folds, candidates[groups], lam, base))
            alpha, self.blend_error_ = blend_weights(np.stack(preds), Yk, row_ids, cfg.blend_steps)
            chosen = [(f, g, lam, float(a)) for (f, g, lam), a in zip(winners, alpha, strict=True) if a > 0]
        else:
            self.blend_error_ = math.nan
            chosen = [("fallback", tuple(cfg.fallback[0]), float(cfg.fallback[1]), 1.0)]
        wn = w / w.sum()
        self.members_: list[Member] = []
        for family, groups, lam, alpha in chosen:
            cols = switching_columns(groups, S)
            prior = _prior_of(groups)
            target = Y - priors[prior] if prior else Y
            if len(cols) and math.isfinite(lam):
                Xc = Xs[:, cols]
                coef = ridge_solve((Xc * wn[:, None]).T @ Xc, (Xc * wn[:, None]).T @ target, lam)
            else:
                cols, coef = np.zeros(0, np.int64), np.zeros((0, Y.shape[1]))
            self.members_.append(Member(family, groups, lam, alpha, cols, coef))
        self.n_outputs_ = Y.shape[1]
        return self

    def displacement(self, rows: np.ndarray, offset: np.ndarray | None, primitive_offset: np.ndarray | None = None) -> np.ndarray:
        """(N, J·3) anchor-frame displacements, metres: Σ_m α_m (prior_m + rows_m W_m) for rows (N, ·) of
        :func:`switching_rows`, the ``from_plan`` prior ``offset`` (N, J·3) (:func:`plan_offset`) and the
        ``from_primitive`` prior ``primitive_offset`` (N, J·3), each read only by members whose prior it is
        (``None`` where no member reads it)."""
        if not hasattr(self, "members_"):
            raise NotFittedError("switching regression: call fit(...) before displacement")
        priors = {"from_plan": offset, "from_primitive": primitive_offset}
        out = np.zeros((len(rows), self.n_outputs_))
        for m, (prior, scale, lower, upper) in zip(self.members_, self._member_tables(), strict=True):
            given = priors[prior] if prior else None
            if prior and given is None:
                raise ModelError(f"switching regression: a member's prior is {prior!r}: pass its offset")
            part = np.array(given, dtype=np.float64) if given is not None else np.zeros_like(out)
            if len(m.columns):
                x = rows[:, m.columns] / scale
                if self.config.clip_features:  # no linear extrapolation beyond the training rows
                    x = x.clip(lower, upper)  # what np.clip calls
                part += x @ m.coefficients
            out += m.weight * part
        return out

    def _member_tables(self) -> tuple[tuple[str | None, np.ndarray, np.ndarray, np.ndarray], ...]:
        """Per member: its prior and the scales and clip bounds of its columns (the same selections of ``scale_``,
        ``lower_`` and ``upper_`` as at every call), made once per fit: the reactor reads them at every frame."""
        cache = self.__dict__.get("_tables")
        if cache is None or cache[0] is not self.members_:
            cache = self._tables = (self.members_, tuple(
                (m.prior, self.scale_[m.columns], self.lower_[m.columns], self.upper_[m.columns]) for m in self.members_))
        return cache[1]

    @property
    def groups_(self) -> tuple[str, ...]:
        """The groups the blend reads (union over its members; ``()``: ``hold``)."""
        return tuple(dict.fromkeys(g for m in getattr(self, "members_", ()) for g in m.groups))

    @property
    def uses_primitive(self) -> bool:
        """Whether the blend reads the interaction primitive (``primitive`` or ``from_primitive``)."""
        return any(g in ("primitive", "from_primitive") for g in self.groups_)

    @property
    def uses_model(self) -> bool:
        """Whether the blend reads a model of the class (a group of :data:`MODEL_GROUPS`: the affordance model's,
        or the interaction primitive's)."""
        return any(g in MODEL_GROUPS for g in self.groups_)
