"""The interaction primitive's causal prediction on a stream, with work and memory bounded per frame.

:meth:`InteractionPrimitive.react_keys <.interaction_primitive.InteractionPrimitive.react_keys>` recomputes
everything from all the frames seen at each call (O(t) work at frame t). :class:`PrimitiveStream` gives the
same outputs (to rounding) from running sums updated with the new frames only:

- per candidate duration T̂ (:attr:`~.interaction_primitive.InteractionPrimitive.durations_`) and degree of
  freedom d, the information HᵀR⁻¹H (an N×N block) and HᵀR⁻¹y of the frames seen, each frame at phase
  min(s / (T̂ − 1), 1);
- per candidate, the duration match's squared error (agent 0's and the object's track relative to its first
  frame against the candidate's mean trajectory), summed over the frames s < T̂;
- the conditioning in two blocks, agent 0 and the object (a) and agent 1 (r): agent 1 is seen only in its
  first T0 frames, so its block Λ_rr = P_rr + B_r of the information matrix is fixed once the stream starts.
  Per candidate, a Cholesky factor of Λ_rr, K = Λ_rr⁻¹ P_ra and the Schur complement S = P_aa − P_ar K are
  computed once; a frame then factors only S + B_a (the a-block, 216×216 with an object, instead of the whole
  396×396), and the posterior mean is read for the frames asked for only.

Gaps: a key joint's missing frames are interpolated between its tracked ones (held after the last), as
:meth:`~socialaff_sim.data.interaction.Interaction.filled_joints` does on the whole view; when a gap closes,
the held values of its frames are replaced by the interpolated ones in the running sums (each frame once,
so the work is bounded on average). A key joint of agent 0 first tracked after frame 0 changes the filled
first frame (and possibly the canonical frame): the stream then rebuilds its sums from the view, once.

Beyond the longest training duration T_max (the bounded rule, docs/design.md §8): the batch estimate would
take the frames seen so far as the duration (phase t / (t − 1), every past frame's phase changing at each
frame); the stream keeps T̂ = T_max, and every later frame is an observation at phase 1 (what
:meth:`~.interaction_primitive.InteractionPrimitive.predict_key_joints` does with ``duration=T_max``). The a-block
then grows by w·φ(1)φ(1)ᵀ per observed DoF and frame, a fixed low-rank term: the stream factors it once every
:data:`PHASE_ONE_REFACTOR` frames and solves the frames between with the Woodbury identity
(:class:`~.low_rank_solve.LowRankUpdatedSolver`; equal in exact arithmetic, to rounding in floating point).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve
from scipy.linalg.lapack import dpotrf, dpotrs

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ConfigError, ModelError, choices
from ..model.frame import CanonicalFrame, canonical_frame
from .interaction_primitive import InteractionPrimitive, rbf_centres, rbf_rows
from .compiled import KERNELS
from .low_rank_solve import LowRankUpdatedSolver
from .primitive_conditioning import SHARED_SOLVERS, add_blocks, fixed_parts, warm_fixed_parts
from .primitive_kernel import UpdatedFactor
from .primitive_sums import PrimitiveSums, diagonal_blocks
from .protocol import observed_part

__all__ = ["PHASE_ONE_REFACTOR", "PrimitiveStream", "SHARED_SOLVERS", "stream_key_joints"]

PHASE_ONE_REFACTOR = 256
"""[frames]: past T_max, the a-block S + B_a is factored anew after this many frames (the frames between solve
against the last factor with the Woodbury identity; the refactoring bounds how far the low-rank term grows from
the factored matrix). A frame that refactors costs what a frame within T_max does."""


class PrimitiveStream(PrimitiveSums):
    """The causal prediction of a fitted :class:`~.interaction_primitive.InteractionPrimitive` on one
    instance whose view grows (module docstring).

    ``n_observed``: T0, agent 1's frames that are seen. Calls come in order, each with a view that holds at
    least the previous one's frames and ``stop`` ≥ the view's length (as the causal and paper protocols make them).
    """

    def __init__(self, primitive: InteractionPrimitive, n_observed: int, kernel: str = "numpy") -> None:
        if not hasattr(primitive, "mean_"):
            raise ModelError("PrimitiveStream: the interaction primitive is not fitted")
        if kernel not in KERNELS:
            raise ConfigError(f"PrimitiveStream kernel: expected {choices(KERNELS)}, found {kernel!r}")
        # kernel "numba": the a-block's factor updated frame after frame within T_max (:mod:`.primitive_kernel`).
        self._factor = UpdatedFactor.for_kernel(kernel)
        self.primitive = primitive
        self.n_observed = int(n_observed)
        cfg = primitive.config
        self._n = cfg.n_basis
        self._d0 = primitive.n_dof_agent0_
        self._cands = primitive.durations_.astype(np.int64)
        self.t_max = int(self._cands.max())
        """T_max, frames: the longest candidate duration (the longest training instance)."""
        n_dof = len(primitive.mean_) // self._n
        self._n_dof = n_dof
        self._inv_var = np.where(np.arange(n_dof) < self._d0, 1.0 / cfg.human_noise**2, 1.0 / cfg.obs_noise**2)
        self._mean = primitive.mean_.reshape(n_dof, self._n)
        self._a = self._d0 * self._n  # size of the agent-0 (and object) block
        self._width = cfg.basis_width
        self._centres, self._sigma = rbf_centres(self._n, self._width)  # rbf_basis's, once (not per frame)
        self._joint_names: tuple[str, ...] = ()
        self._frames_seen = 0
        self._frame: CanonicalFrame | None = None
        self._solvers: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        # Past T_max (module docstring): the a-block's factor at the last refactoring, its candidate and the frames
        # added since; U = I ⊗ φ(1), one column per agent-0 (and object) DoF.
        self._phase_one: LowRankUpdatedSolver | None = None
        self._phase_one_c = -1
        self._phase_one_frames = 0
        self._u_one = np.kron(np.eye(self._d0), self._rbf(np.ones(1)).reshape(-1, 1))  # (a, d0)
        # The basis rows of every candidate at every frame s ≤ T_max (phase min(s / (T̂ − 1), 1); frames past T_max
        # read row T_max, at phase 1 for every candidate): (T_max + 1, candidates, N), each row rbf_rows's value at
        # its phase (a row depends on its own phase only), read per frame instead of evaluated.
        spans = np.maximum(self._cands - 1, 1)
        phases = np.minimum(np.arange(self.t_max + 1)[:, None] / spans[None], 1.0)
        self._table = self._rbf(phases.ravel()).reshape(self.t_max + 1, len(self._cands), self._n)
        self._lam = np.empty((self._a, self._a), order="F")  # the a-block, factored in place every frame within T_max
        self._lam_blocks = diagonal_blocks(self._lam, self._d0, self._n)  # its diagonal N×N blocks, a strided view
        self._row = np.empty(n_dof)  # one frame's DoFs
        self._col_runs: dict[bytes, object] = {}  # what the per-frame sums read of a pattern of seen DoFs
        self._key_cols = slice(0, 3 * len(primitive.keys_))
        self.duration: int | None = None
        """T̂ of the last call, frames."""

    # ----------------------------------------------------------------------------------------- state
    @property
    def state_size(self) -> int:
        """Floats the stream holds (running sums and cached factors): it does not grow with the frames seen."""
        sums = self._hth.size + self._hty.size + self._err.size + self._last_value.size if self._frames_seen else 0
        sums += sum(v.size + 1 for _, v, _ in self._log) if self._frames_seen else 0  # frames deferred (at most T_max)
        low_rank = self._phase_one.size if self._phase_one is not None else 0
        return int(sums + low_rank + sum(sum(a.size for a in s) for s in self._solvers.values()))

    def _rbf(self, phase: np.ndarray) -> np.ndarray:
        """(G, N) :func:`~.interaction_primitive.rbf_basis` at phases (G,)."""
        return rbf_rows(phase, self._centres, self._sigma)

    def _dofs(self, joints: np.ndarray, obj: np.ndarray | None) -> np.ndarray:
        """(G, D) canonical DoFs from world key joints (G, 2, k, 3) and the object (G, 3) or ``None``."""
        assert self._frame is not None
        keys = self._frame.to_canonical(joints)
        parts = [keys[:, 0].reshape(len(keys), -1)]
        if self.primitive.has_object_:
            parts.append(self._frame.to_canonical(obj) if obj is not None else np.full((len(keys), 3), np.nan))
        parts.append((keys[:, 1] - self._anchor).reshape(len(keys), -1))
        return np.concatenate(parts, axis=1)

    def _rebuild(self, view: Interaction) -> None:
        """The sums from scratch over the whole view (the first call, and a key joint first tracked late)."""
        prim = self.primitive
        keys = prim.keys_
        every = view.key_joints()  # filled once: instance_frame's frame and the sums read the same
        self._frame = canonical_frame(every[0, 0, 0], every[0, 1, 0])
        self._joint_names = view.joint_names
        self._idx = np.array([view.layout.key_indices[k] for k in keys], dtype=np.int64)
        filled = every[:, :, keys]  # (T, 2, k, 3) world
        self._anchor = (self._frame.to_canonical(filled[0, 1, 0]) if prim.config.relative_to_start else np.zeros(3))
        y = self._dofs(filled, view.object)
        n_c, n_dof, n = len(self._cands), self._n_dof, self._n
        self._hth = np.zeros((n_c, n_dof, n, n))
        self._hty = np.zeros((n_c, n_dof, n))
        self._err = np.zeros(n_c)
        self._first = y[0, : self._d0].copy()
        self._mu0 = self._rbf(np.zeros(1))[0] @ self._mean[: self._d0].T  # (d0,)
        self._solvers = {}
        self._phase_one = None
        self._reset_log()
        self._add(np.arange(view.n_frames), y)
        # Agent 0's key joints: the last tracked frame and its (canonical) value, for holding and gaps.
        valid = view.key_valid()[:, 0][:, keys]  # (T, k)
        self._tracked = valid.any(axis=0)
        self._last_frame = np.where(self._tracked, view.n_frames - 1 - np.argmax(valid[::-1], axis=0), -1)
        self._last_value = self._frame.to_canonical(filled[np.maximum(self._last_frame, 0), 0, np.arange(len(keys))])
        self._frames_seen = view.n_frames

    def _ingest(self, view: Interaction, T: int) -> None:
        """Add the new frames of the view of ``view``'s first ``T`` frames (``view`` itself when T is its length),
        holding untracked key joints and closing the gaps that end."""
        keys = self.primitive.keys_
        if T < self._frames_seen:
            raise ModelError(f"PrimitiveStream: views must grow; had {self._frames_seen} frames, got {T}")
        idx = self._idx
        row = self._row
        for s in range(self._frames_seen, T):
            valid = view.valid[s, 0, idx] if view.valid is not None else np.ones(len(idx), bool)
            every = bool(valid.all())
            if not every and (valid & ~self._tracked).any() or every and not self._tracked.all():
                self._rebuild(view.slice(0, s + 1))  # first tracked after frame 0: the filled past changes
                continue
            assert self._frame is not None
            raw = self._frame.to_canonical(view.joints[s, 0, idx])  # (k, 3)
            value = raw if every else np.where(valid[:, None], raw, self._last_value)
            row.fill(np.nan)  # agent 1 is not seen after the prefix
            row[self._key_cols] = value.ravel()
            if self.primitive.has_object_ and view.object is not None:
                row[3 * len(keys) : self._d0] = self._frame.to_canonical(view.object[s])
            self._add_frame(s, row)
            for j in ((s - self._last_frame > 1) if every else valid & (s - self._last_frame > 1)).nonzero()[0]:
                self._close_gap(j, s, raw[j])
            if every:
                self._last_frame[:] = s
                self._last_value = raw
            else:
                self._last_frame = np.where(valid, s, self._last_frame)
                self._last_value = value  # np.where(valid[:, None], raw, the last values) was made above: the same array
        self._frames_seen = T

    def _close_gap(self, joint: int, s: int, value: np.ndarray) -> None:
        """Replace the held values of key joint ``joint``'s frames between its last tracked frame and ``s`` by
        the interpolation to ``value`` (canonical, metres)."""
        lo = int(self._last_frame[joint])
        frames = np.arange(lo + 1, s)
        frac = (frames - lo) / (s - lo)
        old = np.broadcast_to(self._last_value[joint], (len(frames), 3))
        new = self._last_value[joint][None] + frac[:, None] * (value - self._last_value[joint])[None]
        cols = slice(3 * joint, 3 * joint + 3)
        y_old = np.full((len(frames), self._n_dof), np.nan)
        y_new = np.full((len(frames), self._n_dof), np.nan)
        y_old[:, cols], y_new[:, cols] = old, new
        self._add(frames, y_old, -1.0, information=False)
        self._add(frames, y_new, 1.0, information=False)

    # ------------------------------------------------------------------------------------ prediction
    def _choose(self, at_least: int) -> int:
        """Index (into the candidates) of T̂: the best match among the candidates ≥ ``at_least``; past T_max, T_max."""
        lo = int(self._cands.searchsorted(at_least, side="left"))  # the candidates ≥ at_least: [lo, end)
        n_c = len(self._cands)
        if lo == n_c:
            return n_c - 1  # T_max, the bounded rule (module docstring)
        if lo == n_c - 1:
            return lo
        return lo + int(self._err[lo:].argmin())

    def _solver(self, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Candidate ``c``'s fixed part of the conditioning: S = P_aa − P_ar K (a, a), K = Λ_rr⁻¹ P_ra (r, a),
        u = Λ_rr⁻¹ (HᵀR⁻¹y − HᵀR⁻¹H μ)_r (r,) and P_ar u (a,) (module docstring)."""
        if c not in self._solvers:
            d0 = self._d0
            blocks = self._hth[c, d0:]
            chol, k, s_aa = self._fixed(c, blocks)
            rhs_r = (self._hty[c, d0:] - np.einsum("dnm,dm->dn", blocks, self._mean[d0:])).ravel()
            u = cho_solve((chol, True), rhs_r, check_finite=False)
            self._solvers[c] = (s_aa, k, u, self.primitive.precision_[: self._a, self._a :] @ u)
        return self._solvers[c]

    def _fixed(self, c: int, blocks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Λ_rr's Cholesky factor, K and S of candidate ``c`` given agent 1's information blocks B_r ``blocks``
        (r-DoFs, N, N), shared between the streams of one primitive (:func:`~.primitive_conditioning.fixed_parts`)."""
        return fixed_parts(self.primitive, self._a, int(self._cands[c]), blocks)

    def warm(self) -> None:
        """Make every candidate's fixed part for an agent 1 tracked in all of its first T0 frames before the first
        frame, once per primitive and T0 (the reactor's constructor calls it;
        :func:`~.primitive_conditioning.warm_fixed_parts`)."""
        warm_fixed_parts(self.primitive, self.n_observed, self._a, self._cands, self._inv_var[self._d0 :], self._rbf)

    def keys(self, view: Interaction, start: int, stop: int) -> np.ndarray:
        """(stop − start, 5, 3) agent 1's key joints of frames [start, stop), metres, the view's canonical frame
        (as :meth:`~.interaction_primitive.InteractionPrimitive.conditioned_keys` with ``offline=False``)."""
        return self._keys(view, view.n_frames, start, stop)

    def prefix_keys(self, hidden: Interaction, visible: int, start: int, stop: int) -> np.ndarray:
        """:meth:`keys` of the view ``hidden.slice(0, visible)`` without building it (the same values): ``hidden``
        is the whole instance as the protocol hides it (:func:`~.protocol.observed_part`), so that view is the
        causal protocol's :func:`~.protocol.protocol_view` of ``visible`` frames. Each frame's view would be a new
        validated instance; this reads the new frames from ``hidden`` (the training rows' stream, every frame)."""
        if not 0 < visible <= hidden.n_frames:
            raise ModelError(f"PrimitiveStream: expected 1..{hidden.n_frames} visible frames, found {visible}")
        return self._keys(hidden, visible, start, stop)

    def _keys(self, view: Interaction, T: int, start: int, stop: int) -> np.ndarray:
        """:meth:`keys` of the view of ``view``'s first ``T`` frames."""
        prim = self.primitive
        if view.joint_names != self._joint_names and view.layout.name != prim.layout_.name:
            raise ModelError(f"ProMP: trained on layout {prim.layout_.name!r}, asked for {view.layout.name!r}")
        if stop < T or start >= stop:
            raise ModelError(f"PrimitiveStream: expected start < stop with stop ≥ the view's {T} frames, "
                             f"found [{start}, {stop})")
        if self._frames_seen == 0:
            self._rebuild(view if T == view.n_frames else view.slice(0, T))
        else:
            self._ingest(view, T)
        c = self._choose(stop)
        self.duration = int(self._cands[c])
        # Candidates shorter than the frames seen are never chosen again (T̂ ≥ stop ≥ the view's length): drop their
        # fixed parts (about 0.7 MB each on the handovers), so a long stream keeps T_max's only.
        for k in [k for k in self._solvers if self._cands[k] < self._frames_seen and k != c]:
            del self._solvers[k]
        self.flush(c)  # its deferred frames (the other candidates' wait until they are read)
        s_aa, k_ra, u, p_u = self._solver(c)
        d0, n = self._d0, self._n
        blocks = self._hth[c, :d0]
        rhs_a = (self._hty[c, :d0] - np.einsum("dnm,dm->dn", blocks, self._mean[:d0])).ravel()
        rhs = rhs_a - p_u
        factor = self._factor
        if self._frames_seen >= self.t_max and self._cands[c] == self.t_max:  # every later frame at phase 1
            x_a = self._phase_one_solve(c, s_aa, blocks, rhs)
            if factor is not None:
                factor.forget()
        elif factor is not None and factor.usable(c):  # the compiled path: the last factor updated by the new frames
            x_a = factor.solve(self._lam, self._table[:, c], self.t_max, rhs)
        else:
            lam = self._a_block(s_aa, blocks)
            # LAPACK's potrf/potrs called as scipy's cho_factor/cho_solve call them (the same arguments, the same
            # values), without their per-call checks: this runs at every frame.
            chol, info = dpotrf(lam, lower=1, clean=0, overwrite_a=1)
            if info != 0:
                raise ModelError(f"PrimitiveStream: the conditioning at frame {start} is not positive definite (potrf {info})")
            x_a, info = dpotrs(chol, rhs, lower=1)
            if factor is not None:
                factor.factored(c, chol, self._lam)
        w_r = self._mean[d0:] + (u - k_ra @ x_a).reshape(-1, n)  # (D − d0, N) agent 1's posterior mean weights
        frames = np.arange(start, stop)
        phi = self._table[np.minimum(frames, self.t_max), c]  # (F, N) the basis at min(s / (T̂ − 1), 1)
        out = np.full((len(frames), N_KEY, 3), np.nan)
        out[:, prim.keys_] = (phi @ w_r.T).reshape(len(frames), len(prim.keys_), 3) + self._anchor
        return out

    def _a_block(self, s_aa: np.ndarray, blocks: np.ndarray) -> np.ndarray:
        """S + B_a (a, a) in the stream's Fortran-ordered buffer (as LAPACK reads it: no copy in the call), from S
        (a, a) and the diagonal blocks B_a (d0, N, N). S is exactly symmetric (0.5 (S + Sᵀ), :meth:`_fixed`), so Sᵀ,
        Fortran-ordered, is S itself: a contiguous copy instead of a transposing one; the blocks added through a
        strided view of the buffer instead of a fancy-indexed read, add and write (the same sums, bitwise)."""
        lam = self._lam
        np.copyto(lam, s_aa.T)
        if self._lam_blocks.base is not lam:  # a copied stream (deepcopy, pickle) holds the view apart from lam
            self._lam_blocks = diagonal_blocks(lam, self._d0, self._n)
        self._lam_blocks += blocks
        return lam

    def _phase_one_solve(self, c: int, s_aa: np.ndarray, blocks: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """(a,) (S + B_a)⁻¹ rhs past T_max: against the last factor and the phase-1 frames added since (Woodbury),
        refactoring S + B_a (as within T_max) when there is none for candidate ``c`` or it is
        :data:`PHASE_ONE_REFACTOR` frames old; on a refactoring frame the solve is the direct one."""
        if self._phase_one is None or self._phase_one_c != c or self._phase_one_frames >= PHASE_ONE_REFACTOR:
            self._phase_one = LowRankUpdatedSolver(add_blocks(s_aa.copy(), blocks), self._u_one)
            self._phase_one_c, self._phase_one_frames = c, 0
        return self._phase_one.solve(rhs)

    def react_keys(self, view: Interaction, start: int, stop: int) -> np.ndarray:
        """:meth:`keys` in the world frame (metres)."""
        keys = self.keys(view, start, stop)
        assert self._frame is not None
        return self._frame.to_world(keys)

    def react_prefix_keys(self, hidden: Interaction, visible: int, start: int, stop: int) -> np.ndarray:
        """:meth:`prefix_keys` in the world frame (metres)."""
        keys = self.prefix_keys(hidden, visible, start, stop)
        assert self._frame is not None
        return self._frame.to_world(keys)


def stream_key_joints(primitive: InteractionPrimitive, interaction: Interaction, n_observed: int, *, stride: int = 1) -> np.ndarray:
    """(T, 5, 3) metres, world: agent 1's key joints at every frame t ≥ T0 = ``n_observed`` from one
    :class:`PrimitiveStream` fed the causal protocol's views (frames [0, t] for frame t), as the full method's
    reactor predicts them; NaN before T0 (:meth:`~.interaction_primitive.InteractionPrimitive.causal_key_joints`
    to rounding, but for the duration past the longest training instance). ``stride`` k > 1: predicted at frames
    T0, T0 + k, … only (NaN at the others; the stream still reads every frame, so those frames' values are the
    same)."""
    if stride < 1:
        raise ModelError(f"stream_key_joints: expected a stride >= 1, found {stride}")
    out = np.full((interaction.n_frames, N_KEY, 3), np.nan)
    if interaction.n_frames <= n_observed:
        return out
    stream = PrimitiveStream(primitive, n_observed)
    hidden = observed_part(interaction, n_observed)  # its first t + 1 frames: protocol_view(interaction, t + 1, n_observed)
    for t in range(n_observed, interaction.n_frames, stride):
        out[t] = stream.react_prefix_keys(hidden, t + 1, t, t + 1)[0]
    return out
