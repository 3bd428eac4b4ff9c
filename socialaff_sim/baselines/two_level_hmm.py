"""A two-level discrete HMM learned by EM (Baum–Welch), the core of the HMM baseline.

Level 1: a hidden *phase* z_t ∈ {0..S-1} of the interaction, a Markov chain
    p(z_0), p(z_t | z_{t-1}).
Level 2: the synthesized agent's pose cluster r_t ∈ {0..K-1}, a Markov chain
    whose transitions depend on the current phase: p(r_0 | z_0), p(r_t | r_{t-1}, z_t).
Emissions: discrete channels, conditionally independent given the state;
    *phase channels* (here the human's pose cluster and the object's status) are
    emitted by the phase, p(x_{t,c} | z_t), *agent channels* (here the quantized
    distance and orientation between the agents) by the agent's cluster,
    p(x_{t,c} | r_t). A channel value of −1 is missing and contributes nothing.
    r_t itself is observed in training (−1 for unobserved frames) and hidden at
    prediction time.

Inference runs on the product state (z, r), index ``z * K + r``, with
:mod:`.hmm_core`. EM maximizes the log-likelihood plus a symmetric Dirichlet
log prior with pseudo-count α on every distribution (α = 0: maximum likelihood);
the objective never decreases.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import ModelError, NotFittedError
from .hmm_core import forward_backward, forward_filter, safe_log

__all__ = ["TwoLevelHMM", "HMMSequence"]

HMMSequence = tuple[np.ndarray, np.ndarray]
"""One sequence: channel symbols (T, C) int64 (phase channels, then agent channels; −1 missing) and agent clusters (T,) int64 (−1 missing)."""


def _normalize(counts: np.ndarray, alpha: float) -> np.ndarray:
    c = counts + alpha
    total = c.sum(axis=-1, keepdims=True)
    uniform = np.full_like(c, 1.0 / c.shape[-1])
    return np.where(total > 0, c / np.where(total > 0, total, 1.0), uniform)


class TwoLevelHMM:
    """Two-level HMM over phases and agent pose clusters (see the module docstring).

    Learned attributes: ``start_phase_`` (S,), ``trans_phase_`` (S, S),
    ``start_agent_`` (S, K), ``trans_agent_`` (S, K, K) indexed [z_t, r_{t-1}, r_t],
    ``emit_`` list of (S, K_c) per phase channel, ``agent_emit_`` list of (K, K_c)
    per agent channel, ``objective_history_`` and
    ``log_likelihood_history_`` (one entry per EM iteration, natural log).
    """

    def __init__(
        self,
        n_phases: int,
        n_agent_clusters: int,
        channel_sizes: Sequence[int],
        agent_channel_sizes: Sequence[int] = (),
        *,
        pseudo_count: float = 0.1,
        max_iter: int = 50,
        tol: float = 1e-5,
    ) -> None:
        if n_phases < 1 or n_agent_clusters < 1 or any(int(k) < 1 for k in (*channel_sizes, *agent_channel_sizes)):
            raise ModelError(
                f"TwoLevelHMM: expected positive sizes, found S = {n_phases}, K = {n_agent_clusters}, "
                f"channels = {list(channel_sizes)} and {list(agent_channel_sizes)}"
            )
        self.n_phases = int(n_phases)
        self.n_agent_clusters = int(n_agent_clusters)
        self.channel_sizes = tuple(int(k) for k in channel_sizes)
        self.agent_channel_sizes = tuple(int(k) for k in agent_channel_sizes)
        self.pseudo_count = float(pseudo_count)
        self.max_iter = int(max_iter)
        self.tol = float(tol)

    # -- the flat product-state model ----------------------------------------------------
    def _check_fitted(self) -> None:
        if not hasattr(self, "emit_"):
            raise NotFittedError("TwoLevelHMM: call fit(...) first")

    def flat_parameters(self) -> tuple[np.ndarray, np.ndarray]:
        """log start (S·K,) and log transitions (S·K, S·K) of the product chain over (z, r)."""
        self._check_fitted()
        S, K = self.n_phases, self.n_agent_clusters
        log_start = (safe_log(self.start_phase_)[:, None] + safe_log(self.start_agent_)).reshape(S * K)
        # [z, r, z', r'] = log p(z'|z) + log p(r'|r, z')
        log_trans = safe_log(self.trans_phase_)[:, None, :, None] + np.transpose(safe_log(self.trans_agent_), (1, 0, 2))[None]
        return log_start, log_trans.reshape(S * K, S * K)

    def log_emissions(self, channels: np.ndarray, agent: np.ndarray) -> np.ndarray:
        """(T, S·K) log p(observations at t | z_t, r_t) for symbols (T, C) and agent clusters (T,)."""
        self._check_fitted()
        x = np.asarray(channels, dtype=np.int64)
        r = np.asarray(agent, dtype=np.int64)
        T, C = x.shape
        if C != self._n_channels or r.shape != (T,):
            raise ModelError(f"TwoLevelHMM: expected symbols (T, {self._n_channels}) and (T,), found {x.shape}, {r.shape}")
        S, K = self.n_phases, self.n_agent_clusters
        out = np.zeros((T, S, K))
        for c, table in enumerate(self.emit_):
            seen = x[:, c] >= 0
            out[seen] += safe_log(table[:, x[seen, c]]).T[:, :, None]
        for c, table in enumerate(self.agent_emit_, start=len(self.emit_)):
            seen = x[:, c] >= 0
            out[seen] += safe_log(table[:, x[seen, c]]).T[:, None, :]
        seen = r >= 0
        mask = np.where(np.arange(K)[None] == r[seen, None], 0.0, -np.inf)
        out[seen] += mask[:, None, :]
        return out.reshape(T, S * K)

    def filter(self, channels: np.ndarray, agent: np.ndarray) -> np.ndarray:
        """(T, S, K) causal posteriors p(z_t, r_t | observations up to t)."""
        log_start, log_trans = self.flat_parameters()
        post, _ = forward_filter(log_start, log_trans, self.log_emissions(channels, agent))
        return post.reshape(-1, self.n_phases, self.n_agent_clusters)

    def log_likelihood(self, sequences: Sequence[HMMSequence]) -> float:
        """Sum over sequences of log p(sequence) (natural log)."""
        log_start, log_trans = self.flat_parameters()
        return float(sum(forward_filter(log_start, log_trans, self.log_emissions(x, r))[1] for x, r in sequences))

    def log_prior(self) -> float:
        """Symmetric Dirichlet log density (up to a constant) of the parameters: α · Σ log θ."""
        if self.pseudo_count == 0.0:
            return 0.0
        tables = [self.start_phase_, self.trans_phase_, self.start_agent_, self.trans_agent_, *self.emit_, *self.agent_emit_]
        return float(self.pseudo_count * sum(safe_log(t).sum() for t in tables))

    # -- learning --------------------------------------------------------------------
    def _m_step(self, stats: dict[str, object]) -> None:
        a = self.pseudo_count
        self.start_phase_ = _normalize(stats["start"].sum(axis=1), a)  # type: ignore[union-attr]
        self.start_agent_ = _normalize(stats["start"], a)  # type: ignore[arg-type]
        xi = stats["xi"]  # [z, r, z', r']
        self.trans_phase_ = _normalize(xi.sum(axis=(1, 3)), a)  # type: ignore[union-attr]
        self.trans_agent_ = _normalize(xi.sum(axis=0).transpose(1, 0, 2), a)  # type: ignore[union-attr]
        self.emit_ = [_normalize(c, a) for c in stats["emit"]]  # type: ignore[union-attr]
        self.agent_emit_ = [_normalize(c, a) for c in stats["agent_emit"]]  # type: ignore[union-attr]

    def _empty_stats(self) -> dict[str, object]:
        S, K = self.n_phases, self.n_agent_clusters
        return {
            "start": np.zeros((S, K)),
            "xi": np.zeros((S, K, S, K)),
            "emit": [np.zeros((S, k)) for k in self.channel_sizes],
            "agent_emit": [np.zeros((K, k)) for k in self.agent_channel_sizes],
        }

    @property
    def _n_channels(self) -> int:
        return len(self.channel_sizes) + len(self.agent_channel_sizes)

    def _accumulate(self, stats: dict[str, object], x: np.ndarray, gamma: np.ndarray, xi: np.ndarray) -> None:
        """Add one sequence's posteriors gamma (T, S, K) and xi (S, K, S, K) to the statistics."""
        stats["start"] += gamma[0]  # type: ignore[operator]
        stats["xi"] += xi  # type: ignore[operator]
        phase, agent = gamma.sum(axis=2), gamma.sum(axis=1)
        for c, counts in enumerate(stats["emit"]):  # type: ignore[arg-type]
            seen = x[:, c] >= 0
            np.add.at(counts.T, x[seen, c], phase[seen])
        for c, counts in enumerate(stats["agent_emit"], start=len(self.channel_sizes)):  # type: ignore[arg-type]
            seen = x[:, c] >= 0
            np.add.at(counts.T, x[seen, c], agent[seen])

    def _initial_stats(self, sequences: Sequence[HMMSequence], rng: np.random.Generator) -> dict[str, object]:
        """Soft left-to-right phases (phase ≈ S·t/T, jittered by ``rng``) as the first E-step."""
        S, K = self.n_phases, self.n_agent_clusters
        stats = self._empty_stats()
        for x, r in sequences:
            T = len(r)
            centre = (np.arange(T) + 0.5) * S / T - 0.5
            q = np.exp(-0.5 * ((np.arange(S)[None] - centre[:, None]) / 0.6) ** 2)
            q *= rng.uniform(0.8, 1.2, size=q.shape)
            q /= q.sum(axis=1, keepdims=True)
            agent = np.where(r[:, None] >= 0, np.arange(K)[None] == r[:, None], 1.0 / K)
            gamma = q[:, :, None] * agent[:, None, :]
            xi = np.einsum("tab,tcd->abcd", gamma[:-1], gamma[1:])
            self._accumulate(stats, x, gamma, xi)
        return stats

    def fit(self, sequences: Sequence[HMMSequence], *, rng: np.random.Generator) -> TwoLevelHMM:
        """Baum–Welch from a jittered left-to-right start until the objective gains < ``tol`` per frame."""
        seqs = [(np.asarray(x, dtype=np.int64), np.asarray(r, dtype=np.int64)) for x, r in sequences]
        if not seqs:
            raise ModelError("TwoLevelHMM: expected at least one training sequence, found none")
        for x, r in seqs:
            if x.ndim != 2 or x.shape != (len(r), self._n_channels) or len(r) == 0:
                raise ModelError(
                    f"TwoLevelHMM: expected symbols (T, {self._n_channels}) and clusters (T,), found {x.shape}, {r.shape}"
                )
            if (x >= np.array(self.channel_sizes + self.agent_channel_sizes)).any() or (r >= self.n_agent_clusters).any():
                raise ModelError("TwoLevelHMM: a symbol is out of range for its channel")
        n_frames = sum(len(r) for _, r in seqs)
        S, K = self.n_phases, self.n_agent_clusters
        self._m_step(self._initial_stats(seqs, rng))
        self.log_likelihood_history_: list[float] = []
        self.objective_history_: list[float] = []
        for _ in range(self.max_iter):
            log_start, log_trans = self.flat_parameters()
            stats = self._empty_stats()
            total = 0.0
            for x, r in seqs:
                fb = forward_backward(log_start, log_trans, self.log_emissions(x, r))
                total += fb.log_likelihood
                self._accumulate(stats, x, fb.gamma.reshape(-1, S, K), fb.xi.reshape(S, K, S, K))
            objective = total + self.log_prior()
            self.log_likelihood_history_.append(total)
            self.objective_history_.append(objective)
            self._m_step(stats)
            if len(self.objective_history_) > 1 and objective - self.objective_history_[-2] < self.tol * n_frames:
                break
        return self
