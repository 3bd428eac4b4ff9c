"""The end-configuration step of Algorithm 2: candidate configurations of agent 1's key joints at the predicted
end of a sub-event, their scores and the one kept.

:class:`CandidatePlanner` is mixed into :class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer` and reads its
episode state (``model``, ``config``, the canonical working track ``_track``, the generator ``_rng``, the
joints ``_available``); subclasses (the tests) override :meth:`CandidatePlanner._select` and
:meth:`CandidatePlanner._score` to watch each re-planning's candidates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..data.skeletons import N_KEY
from ..model.nan_fill import nan_to_zero
from ..model.potentials import reference_weights
from .candidates import AGENT1 as _AGENT1
from .candidates import RegressionPrior, SignTerms, draw_from, expected_error_choice, gaussian_factor, vector_rows
from .model_cache import per_model
from .row_density import compiled_kernels
from .synthesis_config import SynthesisConfig
from .type_tables import TypeTables

if TYPE_CHECKING:
    from ..model.affordance import AffordanceParameters

__all__ = ["CandidatePlanner"]

_OTHERS = np.r_[np.arange(N_KEY), 2 * N_KEY]


def _fixed(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``: the compiled kernels' inputs that do not change within a stream are passed read-only
    whatever their source (a cached plan's, made anew), so that numba compiles one specialisation of each kernel."""
    v = a.view()
    v.flags.writeable = False
    return v


_NO_INT, _NO_ROWS, _NO_UP = _fixed(np.zeros(0, np.int64)), _fixed(np.zeros((0, 2 * N_KEY + 1))), _fixed(np.zeros((2, 0)))
_NO_L, _NO_MEAN = _fixed(np.zeros((0, 0))), np.zeros((N_KEY, 3))
_A1 = _fixed(_AGENT1)
_LOG_2PI_NP = np.log(2.0 * np.pi)  # RegressionPrior.log_density's factor, the same NumPy float


@dataclass(frozen=True)
class _TypePlan:
    """What a re-planning reads of one sub-event type that depends only on the model and the episode's joints:
    made at its first re-planning, read at the next ones (the same arrays, so the same values)."""

    z: np.ndarray
    """(11,) the type's grouping, absent joints −1 (read-only)."""
    aff: np.ndarray
    """(A,) agent 1's affordable joints: those sampled."""
    static: np.ndarray
    """Agent 1's present joints not sampled: they follow the base."""
    weights: np.ndarray
    """(A, 11) the sampled joints' reference weights."""
    spatial: tuple[np.ndarray, ...]
    """The sampled joints' spatial parameter columns (:func:`~.candidates.vector_rows`)."""
    motion: tuple[np.ndarray, ...]
    """Their motion parameter columns."""
    up: np.ndarray
    """(2, A) P(dz > 0) of their spatial offsets and displacements (½ without ``vertical_sign``)."""
    sign: SignTerms | None
    """The vertical-sign terms (None without ``vertical_sign``)."""
    factor: tuple[np.ndarray, float] | None
    """The end regression's covariance factor (None without one)."""


class CandidatePlanner:
    """Draw, score and choose agent 1's end configuration (a mixin of the online synthesizer)."""

    model: AffordanceParameters
    config: SynthesisConfig
    _track: np.ndarray
    _rng: np.random.Generator
    _available: np.ndarray
    _refw: dict[int, np.ndarray]
    _tables: TypeTables | None

    def _type_plan(self, s: int) -> _TypePlan:
        """Type ``s``'s :class:`_TypePlan`, made once per fitted model, settings read (``vertical_sign``,
        ``end_prior``) and episode joints ``_available`` (:func:`~.model_cache.per_model`; every recording of one
        model has the model's joints), read-only: the same arrays at every re-planning of every recording, so the
        same values. Every type's plan is made at once, so that the reactor's state does not change size later in a
        stream."""
        cache = self.__dict__.get("_plans")
        if cache is None or cache[0] is not self._refw:  # looked up once per episode (reset renews _refw)
            cfg = self.config
            key = ("type_plans", cfg.vertical_sign, cfg.end_prior, self._available.tobytes())
            cache = self._plans = (self._refw, per_model(self.model, key, self._make_type_plans))
        return cache[1][s]

    def _make_type_plans(self) -> dict[int, _TypePlan]:
        return {k: self._make_type_plan(k) for k in range(self.model.n_subevents_)}

    def _make_type_plan(self, s: int) -> _TypePlan:
        model, cfg = self.model, self.config
        z = model.grouping_[s].copy()
        z[~self._available] = -1
        aff = _AGENT1[z[_AGENT1] > 0]
        # (2, 11): P(dz > 0) of spatial offsets and of displacements; ½ without the sign term (the paper).
        up = model.vertical_up_[s] if cfg.vertical_sign else np.full_like(model.vertical_up_[s], 0.5)
        W = self._weights(s, z)
        reg = model.end_regression_[s] if cfg.end_prior == "regression" else None
        return _TypePlan(
            z=z, aff=aff, static=_AGENT1[self._available[_AGENT1] & ~np.isin(_AGENT1, aff)], weights=W[aff],
            spatial=vector_rows(model.spatial_params_[s, aff]), motion=vector_rows(model.motion_params_[s, aff]),
            up=up[:, aff], sign=SignTerms.of(model, s, z, W) if cfg.vertical_sign else None,
            factor=None if reg is None else gaussian_factor(reg),
        )

    def _best_configuration(self, s: int, t: int, start: int, last: int) -> np.ndarray:
        """(5, 3) canonical: agent 1's key joints at frame ``last``, the best of N candidates."""
        model, cfg = self.model, self.config
        T = self._track.shape[0]
        config = self._track[t - 1].copy()
        if cfg.lookahead:
            config[_OTHERS] = self._track[min(last, T - 1), _OTHERS]
        before = self._track[max(start - 1, 0)]
        plan = self._type_plan(s)
        z, aff = plan.z, plan.aff
        prev = config[_AGENT1].copy()
        N = cfg.n_samples
        cand = np.repeat(config[None], N, axis=0)
        if aff.size:
            n_sp = int(round(cfg.spatial_fraction * N))
            refs = plan.weights @ nan_to_zero(config)  # (A, 3)
            sp = draw_from(plan.spatial, plan.up[0], n_sp, self._rng) + refs[None]
            mo = draw_from(plan.motion, plan.up[1], N - n_sp, self._rng) + before[aff][None]
            cand[:, aff] = np.concatenate([sp, mo])
            base = N_KEY
            n_co = int(round(cfg.coherent_fraction * N))
            if n_co and base in aff:
                rows = self._rng.permutation(N)[:n_co]
                others = aff[aff != base]
                follow = self._rng.random((n_co, others.size)) < 0.5
                rigid = prev[others - N_KEY][None] + (cand[rows, base] - prev[0])[:, None]
                cand[rows[:, None], others[None]] = np.where(follow[..., None], rigid, cand[rows[:, None], others[None]])
        # Joints not sampled (Null) stay static relative to agent 1's base, which may have moved.
        base = N_KEY
        shift = cand[:, base] - prev[0] if base in aff else np.zeros((N, 3))
        static = plan.static
        cand[:, static] = prev[static - N_KEY][None] + shift[:, None]
        prior = None
        reg = model.end_regression_[s] if cfg.end_prior == "regression" else None
        if reg is not None:
            prior = RegressionPrior.at(reg, config, before, self._track[cfg.n_observed - 1], self._available, plan.factor)
            extra = np.repeat(config[None], cfg.prior_samples, axis=0)
            extra[:, _AGENT1] = prior.draw(cfg.prior_samples, self._rng)
            cand = np.concatenate([cand, extra])
        best = self._select(s, z, cand, before, static, prior)
        out = best[_AGENT1].copy()
        out[~self._available[_AGENT1]] = np.nan
        return out


    def _weights(self, s: int, z: np.ndarray) -> np.ndarray:
        """(11, 11) reference weights of type ``s``'s grouping ``z`` (absent joints masked), once per episode."""
        W = self._refw.get(s)
        if W is None:
            cfg = self.model.config
            W = self._refw[s] = reference_weights(z, other_side=cfg.other_side_reference, include_self=cfg.reference_self)
        return W

    def _score(
        self, s: int, z: np.ndarray, configs: np.ndarray, before: np.ndarray, prior: RegressionPrior | None
    ) -> np.ndarray:
        """(N,) log spatial + log motion (+ vertical signs, + the regression prior) of N configurations (N, 11, 3)."""
        model = self.model
        if self._tables is not None and self.config.kernel == "numba":
            return self._score_compiled(s, z, configs, before, prior)
        disp = configs - before[None]
        if self._tables is not None:  # spatial(configs, s) + motion(disp, s), scored in one pass
            spatial, motion = self._tables.spatial_motion(configs, disp, s)
            score = spatial + motion
        else:
            score = model.log_spatial(s, configs) + model.log_motion(s, disp)
        if self.config.vertical_sign:
            plan = self._type_plan(s)
            same = z is plan.z or np.array_equal(z, plan.z)  # the planner passes the plan's own z
            sign = plan.sign if plan.sign is not None and same else SignTerms.of(model, s, z, self._weights(s, z))
            score = score + sign.loglik(configs, disp)
        if prior is not None:
            score = score + prior.log_density(configs)
        return np.where(np.isnan(score), -np.inf, score)

    def _score_compiled(
        self, s: int, z: np.ndarray, configs: np.ndarray, before: np.ndarray, prior: RegressionPrior | None
    ) -> np.ndarray:
        """:meth:`_score` by the compiled kernel (:func:`~.score_kernel.scores`, with the type tables): the same terms,
        within the tolerance of docs/design.md §7."""
        plan = self._type_plan(s)
        own = z is plan.z or np.array_equal(z, plan.z)  # the planner passes the plan's own z
        args = self._kernel_args(s, z, plan, own)  # ..., the sign terms, then the end regression's L, log det, D log 2π
        if prior is None:
            tail = (0, _A1, _NO_MEAN, *args[-3:])
        elif prior.factor is not None and prior.factor is plan.factor and args[-3] is not _NO_L:
            tail = (1, _A1, np.ascontiguousarray(prior.mean, float), *args[-3:])
        else:  # a prior without the plan's factor (made here, as RegressionPrior.log_density makes it)
            L, logdet = prior.factor if prior.factor is not None else gaussian_factor(prior.regression)
            const = float(prior.regression.cov.shape[0] * _LOG_2PI_NP)
            tail = (1, _A1, np.ascontiguousarray(prior.mean, float), _fixed(L), float(logdet), const)
        return compiled_kernels().scores(
            np.ascontiguousarray(configs, float), np.ascontiguousarray(before, float), *args[:-3], *tail)

    def _kernel_args(self, s: int, z: np.ndarray, plan: _TypePlan, own: bool) -> tuple:
        """The compiled scores' inputs of type ``s`` that do not change within a stream (the type tables' rows, the sign
        terms, the end regression's factor), read-only: made for every type at once for the plans' own groupings and kept
        with the plans (so that the reactor's state does not change size later in a stream), else anew."""
        if not own:
            return self._make_kernel_args(s, z, plan, False)
        cache = self.__dict__.get("_kargs")
        if cache is None or cache[0] is not self._plans[1]:
            args = {k: self._make_kernel_args(k, p.z, p, True) for k, p in self._plans[1].items()}
            cache = self._kargs = (self._plans[1], args)
        return cache[1][s]

    def _make_kernel_args(self, s: int, z: np.ndarray, plan: _TypePlan, own: bool) -> tuple:
        assert self._tables is not None
        sp_joint, w, cols, mo_joint, table = self._tables.score_rows(s)
        sign: SignTerms | None = None
        if self.config.vertical_sign:
            sign = plan.sign if plan.sign is not None and own else SignTerms.of(self.model, s, z, self._weights(s, z))
        if sign is None or not sign.aff.size:
            aff, sign_w, off_up = _NO_INT, _NO_ROWS, _NO_UP
        else:
            aff, sign_w, off_up = _fixed(sign.aff), _fixed(np.ascontiguousarray(sign.weights)), _fixed(sign.offset_up)
        moving, disp_up = (_NO_INT, _NO_UP) if sign is None or not sign.moving.size else (_fixed(sign.moving), _fixed(sign.disp_up))
        reg = self.model.end_regression_[s] if self.config.end_prior == "regression" else None
        if plan.factor is None or reg is None:
            prior = (_NO_L, 0.0, 0.0)
        else:
            prior = (_fixed(plan.factor[0]), float(plan.factor[1]), float(reg.cov.shape[0] * _LOG_2PI_NP))
        return (_fixed(sp_joint), _fixed(w), _fixed(cols), _fixed(mo_joint), _fixed(table), float(self._tables.eps),
                int(sign is not None), aff, sign_w, off_up, moving, disp_up, *prior)

    def _select(
        self, s: int, z: np.ndarray, cand: np.ndarray, before: np.ndarray, static: np.ndarray,
        prior: RegressionPrior | None,
    ) -> np.ndarray:
        """The most likely configuration (11, 3) over the candidates and their per-joint recombinations.

        Start from the best of the N whole candidates, then, joint by joint (``refine_sweeps`` times),
        try each candidate's position of that joint with the others held: a coordinate ascent over
        the N^A combinations of the A sampled joints' draws, on the same objective.
        """
        score = self._score(s, z, cand, before, prior)
        if self.config.selection == "likelihood":
            k = int(np.argmax(score))
        elif self.config.kernel == "numba":  # the same choice, compiled (score_kernel.choice)
            k = int(compiled_kernels().choice(np.ascontiguousarray(cand, float), _A1, score, float(N_KEY)))
        else:  # the potentials score each joint as independent evidence: the product is overconfident, so temper it
            k = expected_error_choice(cand[:, _AGENT1], score, temperature=N_KEY)
        best, best_score = cand[k].copy(), score[k]
        sampled = _AGENT1[z[_AGENT1] > 0]
        base = N_KEY
        for _ in range(self.config.refine_sweeps):
            improved = False
            for j in sampled:
                trial = np.repeat(best[None], cand.shape[0], axis=0)
                trial[:, j] = cand[:, j]
                if j == base:  # the body moves with its base: static joints follow
                    trial[:, static] = best[static][None] + (cand[:, base] - best[base])[:, None]
                sc = self._score(s, z, trial, before, prior)
                i = int(np.argmax(sc))
                if sc[i] > best_score + 1e-12:
                    best, best_score, improved = trial[i].copy(), sc[i], True
            if not improved:
                break
        return best

