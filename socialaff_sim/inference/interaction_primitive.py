"""Interaction primitive: a probabilistic movement primitive over both agents, conditioned on what is seen.

After Maeda et al., "Probabilistic movement primitives for coordination of multiple human–robot
collaborative tasks" (Autonomous Robots 2017). The numerical core shared by the ``promp`` baseline
(:mod:`socialaff_sim.baselines.promp`, which adds the body fit and the evaluation protocol) and the
switching regression's ``primitive`` family (:mod:`.switching`).

Each training instance's trajectories — agent 0's key joints, the object (when the class has one) and
agent 1's key joints, all in the instance's canonical frame — are time-normalized to a phase
s = t / (T − 1) ∈ [0, 1] and projected, degree of freedom by degree of freedom, onto N normalized Gaussian
radial basis functions by ridge-regularized least squares. The stacked weights of all DoFs follow one joint
Gaussian: the sample mean, and the sample covariance shrunk toward its diagonal plus σ_w² I plus the
covariance of constant offsets (per DoF and per agent), which lets the observed prefix shift a whole
trajectory. Agent 1's DoFs are taken relative to its base at the first frame.

Prediction conditions that Gaussian on what the protocol lets a method see — agent 0's track (noise σ_h),
the object's (σ_h), and agent 1's first T0 frames (σ_y) — and reads agent 1's key joints off the posterior
mean.

Phase: online the duration is unknown, so it is estimated from the observed prefix, as Maeda et al. do
(:meth:`InteractionPrimitive.estimate_duration`): among :attr:`ProMPConfig.n_durations` quantiles of the
training durations (at least the frames asked for), the one whose mean agent-0 (and object) trajectory,
relative to its first frame, is nearest (least squares) to the observed prefix relative to its first frame;
frame t then has phase t / (T̂ − 1), clipped to 1 (the phase-ratio search of Interaction ProMPs with the
covariance left out of the match). Offline the whole track is given and T is known.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ModelError, NotFittedError
from ..model.frame import CanonicalFrame, canonical_frame
from .body_fit import BodyFitConfig, instance_frame
from .protocol import PrefixViews

__all__ = ["InteractionPrimitive", "ProMPConfig", "condition_gaussian", "condition_on_statistics", "rbf_basis", "rbf_centres", "rbf_rows"]


@dataclass(frozen=True)
class ProMPConfig:
    """Settings of the Interaction ProMP.

    Maeda et al. tune these per task; ours were chosen on SBU (shaking hands,
    exchanging an object) and the synthetic data (shake hands, hand over) by a
    small grid search under the evaluation protocol — a choice that can only
    favour the baseline.
    """

    n_basis: int = 12
    """N [—]: Gaussian basis functions per degree of freedom."""
    basis_width: float = 1.0
    """h [1/(N−1)]: standard deviation of each basis function, in units of the spacing 1 / (N − 1) of their centres."""
    ridge: float = 1e-2
    """λ [—]: ridge regularization of the per-instance least-squares weight fit (keeps weights of
    overlapping basis functions from oscillating)."""
    prior_var: float = 1e-2
    """σ_w² [m²]: variance added to the diagonal of the weights' covariance, m²."""
    shrinkage: float = 0.5
    """α [—]: the weights' covariance is (1 − α)·S + α·diag(S) + σ_w² I + offsets, S the sample
    covariance of the few demonstrations (shrinking the cross-covariances against overfitting)."""
    offset_var: float = 1e-2
    """σ_o² [m²]: prior variance of a constant offset of each DoF's whole trajectory, m² (normalized
    basis functions sum to one, so an offset adds the same value to all N weights of a DoF)."""
    rigid_offset_var: float = 1e-2
    """σ_r² [m²]: prior variance of a shift of each agent's whole body along each axis, m²."""
    obs_noise: float = 0.01
    """σ_y [m]: observation noise of agent 1's observed prefix when conditioning, metres."""
    human_noise: float = 0.1
    """σ_h [m]: observation noise of agent 0's (and the object's) track when conditioning, metres."""
    relative_to_start: bool = True
    """[—]: Model agent 1's key joints relative to its own base at the first frame (always observed),
    so that where agent 1 happens to stand does not have to be explained by the few demonstrations."""
    n_durations: int = 15
    """[—]: Candidate durations of the causal phase estimate (quantiles of the training durations)."""
    body_fit: BodyFitConfig = field(default_factory=BodyFitConfig)
    """[—]: Full-body fit of the predicted key joints (read by the ``promp`` baseline only)."""
    training_stream: bool = True
    """[—]: The switching regression's training rows (``primitive`` family) read the primitive's causal predictions
    from :class:`~.primitive_stream.PrimitiveStream`, as the reactor does at test (default), instead of the
    conditioning recomputed from every view (:meth:`InteractionPrimitive.causal_key_joints`, ``False``): several
    times faster, equal to rounding, but beyond the longest training instance the stream keeps its duration; the
    development split's error moved by at most 0.0001 m (docs/design.md §8)."""


def rbf_centres(n_basis: int, width: float = 1.0) -> tuple[np.ndarray, float]:
    """The (N,) centres in [0, 1] and the width σ (phase units) of :func:`rbf_basis`'s functions."""
    return np.linspace(0.0, 1.0, n_basis), width / max(n_basis - 1, 1)


def rbf_rows(phase: np.ndarray, centres: np.ndarray, sigma: float) -> np.ndarray:
    """(T, N) normalized Gaussian basis functions with ``centres`` (N,) and width ``sigma`` at phases (T,) (rows sum
    to 1); a caller evaluating the same basis every frame keeps :func:`rbf_centres` once."""
    phi = np.exp(-0.5 * ((np.asarray(phase, dtype=np.float64)[:, None] - centres[None]) / sigma) ** 2)
    return phi / phi.sum(axis=1, keepdims=True)


def rbf_basis(phase: np.ndarray, n_basis: int, width: float = 1.0) -> np.ndarray:
    """(T, N) normalized Gaussian basis functions at phases (T,) in [0, 1] (rows sum to 1)."""
    return rbf_rows(phase, *rbf_centres(n_basis, width))


def condition_on_statistics(
    mean: np.ndarray,
    cov: np.ndarray,
    hth: np.ndarray,
    hty: np.ndarray,
    *,
    precision: np.ndarray | None = None,
    return_cov: bool = True,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Posterior of w ~ N(mean, cov) given y = H w + ε, ε ~ N(0, R), from ``hth`` = Hᵀ R⁻¹ H and ``hty`` = Hᵀ R⁻¹ y.

    Information form: Λ = cov⁻¹ + HᵀR⁻¹H, mean' = mean + Λ⁻¹ Hᵀ R⁻¹ (y − H mean),
    cov' = Λ⁻¹. Its cost does not depend on the number of observations. ``precision``
    (cov⁻¹), when known, saves one inversion; ``return_cov=False`` skips cov' (returns ``None``).
    """
    prec = precision if precision is not None else cho_solve(cho_factor(cov, lower=True), np.eye(len(mean)))
    lam = prec + hth
    lam = 0.5 * (lam + lam.T)
    factor = cho_factor(lam, lower=True)
    new_mean = mean + cho_solve(factor, hty - hth @ mean)
    if not return_cov:
        return new_mean, None
    new_cov = cho_solve(factor, np.eye(len(mean)))
    return new_mean, 0.5 * (new_cov + new_cov.T)


def condition_gaussian(
    mean: np.ndarray, cov: np.ndarray, obs_matrix: np.ndarray, obs: np.ndarray, noise_var: float
) -> tuple[np.ndarray, np.ndarray]:
    """Posterior mean (D,) and covariance (D, D) of w ~ N(mean, cov) given ``obs = obs_matrix @ w + noise``,
    noise ~ N(0, noise_var I)."""
    if noise_var <= 0:
        raise ModelError(f"conditioning: the observation noise variance must be > 0, found {noise_var}")
    h = np.asarray(obs_matrix, dtype=np.float64)
    y = np.asarray(obs, dtype=np.float64)
    new_mean, new_cov = condition_on_statistics(mean, cov, h.T @ h / noise_var, h.T @ y / noise_var)
    return new_mean, cast(np.ndarray, new_cov)


class PrefixBasis:
    """The basis rows ``rbf_basis(min(s / span, 1))`` at frames s = 0 … t − 1, for frame counts t ≤ ``n_frames``:
    computed once per span for all ``n_frames`` frames and read as a prefix (each row is computed from its own phase
    alone, so the prefix is bitwise the rows computed for t frames; ``tests/test_fit_speed.py`` checks it)."""

    def __init__(self, n_basis: int, width: float, n_frames: int) -> None:
        self.n_basis, self.width, self.n_frames = int(n_basis), float(width), int(n_frames)
        self._rows: dict[int, np.ndarray] = {}

    def rows(self, span: int, t: int) -> np.ndarray:
        """(t, N) the basis at phases min(s / ``span``, 1), s < t ≤ ``n_frames`` (frames)."""
        full = self._rows.get(span)
        if full is None:
            full = self._rows[span] = rbf_basis(np.minimum(np.arange(self.n_frames) / span, 1.0), self.n_basis, self.width)
        return full[:t]


class InteractionPrimitive:
    """The joint weight distribution of one class's interactions and its conditioning (module docstring).

    Learned attributes: ``layout_``, ``keys_`` (indices of the key joints the layout has), ``has_object_``,
    ``durations_`` (candidate durations, frames), ``mean_`` (D·N,) and ``cov_`` (D·N, D·N) of the stacked
    weights (DoF-major: weight i of DoF d at d·N + i; DoFs ordered agent 0's key joints × xyz, the object's
    xyz, agent 1's key joints × xyz).
    """

    def __init__(self, config: ProMPConfig | None = None) -> None:
        self.config = config or ProMPConfig()

    def _trajectories(self, inter: Interaction) -> tuple[np.ndarray, np.ndarray]:
        """(T, D) the instance's DoFs in its canonical frame, metres (NaN where never tracked), and
        the (3,) offset subtracted from agent 1's DoFs."""
        y, anchor, _ = self._dofs_of(inter.key_joints(), inter.object)
        return y, anchor

    def _dofs_of(self, key_joints: np.ndarray, obj: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, CanonicalFrame]:
        """:meth:`_trajectories` from an instance's filled key joints (T, 2, 5, 3) world metres and object track
        (T, 3) or ``None``; also returns the instance's canonical frame (:func:`instance_frame`'s)."""
        T = key_joints.shape[0]
        frame = canonical_frame(key_joints[0, 0, 0], key_joints[0, 1, 0])
        keys = frame.to_canonical(key_joints[:, :, self.keys_])  # (T, 2, k, 3)
        parts = [keys[:, 0].reshape(T, -1)]
        if self.has_object_:
            parts.append(frame.to_canonical(obj) if obj is not None else np.full((T, 3), np.nan))
        anchor = keys[0, 1, 0] if self.config.relative_to_start else np.zeros(3)  # agent 1's first base
        parts.append((keys[:, 1] - anchor).reshape(T, -1))
        return np.concatenate(parts, axis=1), anchor, frame

    def weights(self, trajectory: np.ndarray) -> np.ndarray:
        """(D, N) ridge least-squares basis weights of a (T, D) trajectory on phase [0, 1]; NaN columns stay NaN."""
        y = np.asarray(trajectory, dtype=np.float64)
        phi = rbf_basis(np.linspace(0.0, 1.0, len(y)), self.config.n_basis, self.config.basis_width)
        a = phi.T @ phi + self.config.ridge * np.eye(self.config.n_basis)
        return np.linalg.solve(a, phi.T @ np.nan_to_num(y)).T + np.where(np.isnan(y).any(axis=0), np.nan, 0.0)[:, None]

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator | None = None) -> InteractionPrimitive:
        """Learn the joint weight distribution from one class's instances (deterministic: ``rng`` is unused
        here; subclasses may draw from it)."""
        if not interactions:
            raise ModelError("ProMP: expected at least one training interaction, found none")
        layout = interactions[0].layout
        if any(i.layout.name != layout.name for i in interactions):
            raise ModelError("ProMP: all training instances must share one skeleton layout")
        self.layout_ = layout
        self.keys_ = np.flatnonzero(layout.key_available)
        self.has_object_ = all(i.object is not None for i in interactions)
        trajs = [self._trajectories(i)[0] for i in interactions]
        durations = np.array([i.n_frames for i in interactions], dtype=np.float64)
        q = np.quantile(durations, np.linspace(0.0, 1.0, self.config.n_durations))
        self.durations_ = np.unique(np.round(q).astype(np.int64))
        self.n_dof_agent0_ = 3 * len(self.keys_) + (3 if self.has_object_ else 0)
        w = np.stack([self.weights(y).ravel() for y in trajs])
        missing = np.isnan(w)
        if missing.any():  # a DoF never tracked in an instance: impute the other instances' mean
            count = (~missing).sum(axis=0)
            col_mean = np.where(missing, 0.0, w).sum(axis=0) / np.maximum(count, 1)
            w = np.where(missing, col_mean, w)
        self.mean_ = w.mean(axis=0)
        dev = w - self.mean_
        sample = dev.T @ dev / max(len(w) - 1, 1)
        a = self.config.shrinkage
        self.cov_ = (1.0 - a) * sample + a * np.diag(np.diag(sample)) + self.config.prior_var * np.eye(w.shape[1])
        self.cov_ += self._offset_covariance(w.shape[1] // self.config.n_basis)
        self._precision = cho_solve(cho_factor(self.cov_, lower=True), np.eye(w.shape[1]))
        return self

    @property
    def precision_(self) -> np.ndarray:
        """(D·N, D·N) the prior precision ``cov_``⁻¹ of the stacked weights."""
        return cast(np.ndarray, self._precision)

    def _offset_covariance(self, n_dof: int) -> np.ndarray:
        """(D·N, D·N) prior covariance of constant per-DoF offsets and of rigid per-agent shifts."""
        n = self.config.n_basis
        k = len(self.keys_)
        # group[d]: which rigid shift DoF d belongs to (agent, axis); the object moves on its own.
        group = np.full(n_dof, -1)
        group[: 3 * k] = np.tile(np.arange(3), k)
        group[n_dof - 3 * k :] = 3 + np.tile(np.arange(3), k)
        same = (group[:, None] == group[None]) & (group[:, None] >= 0)
        dof_cov = self.config.offset_var * np.eye(n_dof) + self.config.rigid_offset_var * same
        return np.kron(dof_cov, np.ones((n, n)))

    def _check_fitted(self) -> None:
        if not hasattr(self, "mean_"):
            raise NotFittedError("InteractionProMP: call fit(...) before predict(...)")

    def estimate_duration(self, interaction: Interaction, at_least: int) -> int:
        """T̂, frames: the candidate duration (≥ ``at_least``) whose mean agent-0/object trajectory best
        matches the instance's frames so far, both relative to their first frame (module docstring)."""
        self._check_fitted()
        cands = self.durations_[self.durations_ >= at_least]
        if cands.size == 0:
            return int(at_least)
        if cands.size == 1:
            return int(cands[0])
        return self._duration_of(self._trajectories(interaction)[0], cands)

    def _duration_of(self, y: np.ndarray, cands: np.ndarray, basis: PrefixBasis | None = None) -> int:
        """:meth:`estimate_duration` from the instance's DoFs y (T, D) and the candidates (≥ 2 of them, each ≥ T
        when ``basis`` is given: it then supplies the basis rows, which need no clipping)."""
        d0, n, t = self.n_dof_agent0_, self.config.n_basis, y.shape[0]
        obs = y[:, :d0] - y[:1, :d0]
        ok = np.isfinite(obs)
        mean0 = self.mean_.reshape(-1, n)[:d0]  # (d0, N)
        errors = []
        for T_hat in cands:
            span = max(T_hat - 1, 1)
            phi = rbf_basis(np.arange(t) / span, n, self.config.basis_width) if basis is None else basis.rows(span, t)
            mu = phi @ mean0.T
            errors.append(float(np.mean(np.where(ok, obs - (mu - mu[:1]), 0.0) ** 2)))
        return int(cands[int(np.argmin(errors))])

    def predict_key_joints(
        self, interaction: Interaction, *, n_observed: int, duration: int | None = None, visible: int | None = None
    ) -> np.ndarray:
        """(T, 5, 3) agent 1's key joints, canonical frame, metres: the posterior mean trajectory.

        ``duration``: the instance's length used for the phase (default: its own T); frames past it
        have phase 1. ``visible``: agent 0's and the object's frames from this one on are not
        conditioned on (default: all)."""
        self._check_fitted()
        y, anchor = self._trajectories(interaction)
        return self._posterior_keys(y, anchor, n_observed=n_observed, duration=duration, visible=visible)

    def _posterior_keys(
        self, y: np.ndarray, anchor: np.ndarray, *, n_observed: int, duration: int | None, visible: int | None,
        basis: PrefixBasis | None = None,
    ) -> np.ndarray:
        """:meth:`predict_key_joints` from the instance's DoFs y (T, D) and agent 1's offset ``anchor`` (3,)
        (:meth:`_trajectories`); ``basis``: where the basis rows are read (default: computed)."""
        cfg = self.config
        n, T = cfg.n_basis, y.shape[0]
        d0 = self.n_dof_agent0_
        seen = np.isfinite(y)
        seen[n_observed:, d0:] = False  # agent 1 after the prefix is never used
        if visible is not None:
            seen[visible:, :d0] = False  # frames held past the view are no observation
        span = max((duration or T) - 1, 1)
        phi = rbf_basis(np.minimum(np.arange(T) / span, 1.0), n, cfg.basis_width) if basis is None else basis.rows(span, T)
        n_dof = y.shape[1]
        hth = np.zeros((n_dof, n, n_dof, n))
        hty = np.zeros((n_dof, n))
        grams: dict[tuple[bytes, float], np.ndarray] = {}  # DoFs seen in the same frames share HᵀR⁻¹H's block
        for d in range(n_dof):
            rows = phi[seen[:, d]]
            inv_var = 1.0 / (cfg.human_noise if d < d0 else cfg.obs_noise) ** 2
            key = (seen[:, d].tobytes(), inv_var)
            if key not in grams:
                grams[key] = rows.T @ rows * inv_var
            hth[d, :, d, :] = grams[key]
            hty[d] = rows.T @ y[seen[:, d], d] * inv_var
        mean, _ = condition_on_statistics(
            self.mean_, self.cov_, hth.reshape(n_dof * n, -1), hty.ravel(), precision=self._precision, return_cov=False
        )
        traj = phi @ mean.reshape(n_dof, n)[d0:].T  # (T, 3k)
        out = np.full((T, N_KEY, 3), np.nan)
        out[:, self.keys_] = traj.reshape(T, len(self.keys_), 3) + anchor
        return out

    def conditioned_keys(
        self, view: Interaction, start: int, stop: int, *, n_observed: int, offline: bool = False
    ) -> np.ndarray:
        """(stop − start, 5, 3) agent 1's key joints of frames [start, stop), metres, the view's canonical frame:
        conditioned on ``view`` (agent 0 and the object up to its last frame, agent 1's first ``n_observed``), with
        the phase of the view's own duration when ``offline``, else of the duration estimated from it."""
        self._check_fitted()
        if view.layout.name != self.layout_.name:
            raise ModelError(f"ProMP: trained on layout {self.layout_.name!r}, asked for {view.layout.name!r}")
        duration = view.n_frames if offline else self.estimate_duration(view, stop)
        longer = view.extend_held(stop)
        return self.predict_key_joints(longer, n_observed=n_observed, duration=duration, visible=view.n_frames)[start:stop]

    def react_keys(self, view: Interaction, start: int, stop: int, *, n_observed: int, offline: bool = False) -> np.ndarray:
        """:meth:`conditioned_keys` in the world frame (metres)."""
        return instance_frame(view).to_world(self.conditioned_keys(view, start, stop, n_observed=n_observed, offline=offline))

    def causal_key_joints(self, interaction: Interaction, n_observed: int) -> np.ndarray:
        """(T, 5, 3) metres, world: agent 1's key joints at every frame t ≥ T0 = ``n_observed`` as the causal
        protocol asks for them (:meth:`react_keys` with the view of frames [0, t]); NaN before T0."""
        self._check_fitted()
        if interaction.layout.name != self.layout_.name:
            raise ModelError(f"ProMP: trained on layout {self.layout_.name!r}, asked for {interaction.layout.name!r}")
        out = np.full((interaction.n_frames, N_KEY, 3), np.nan)
        if interaction.n_frames <= n_observed:
            return out
        views = PrefixViews(interaction, n_observed)
        basis = PrefixBasis(self.config.n_basis, self.config.basis_width, interaction.n_frames)
        for t in range(n_observed, interaction.n_frames):
            # react_keys on protocol_view(interaction, t + 1, n_observed): the view's key joints filled without
            # building it (PrefixViews), its DoFs once for the duration estimate and the conditioning.
            y, anchor, frame = self._dofs_of(views.key_joints(t + 1), views.object(t + 1))
            cands = self.durations_[self.durations_ >= t + 1]
            duration = t + 1 if cands.size == 0 else int(cands[0]) if cands.size == 1 else self._duration_of(y, cands, basis)
            keys = self._posterior_keys(y, anchor, n_observed=n_observed, duration=duration, visible=t + 1, basis=basis)[t:t + 1]
            out[t] = frame.to_world(keys)[0]
        return out
