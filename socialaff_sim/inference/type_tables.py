"""Every sub-event type's potentials stacked row by row, for scoring many configurations under one or all
types in one vectorised pass.

:meth:`~socialaff_sim.model.affordance.AffordanceParameters.log_spatial` and ``log_motion`` score one type
at a time and rebuild the type's reference weights at every call; the forward belief scores every type at
every cut, and the synthesizer N candidates at every re-planning. :class:`TypeTables` precomputes, once
per model, one row per (type, joint) with its parameters and reference weights, and evaluates the same
densities (:mod:`~socialaff_sim.model.densities`, polar vector densities) for all rows at once; summed
per type they equal the model's scores (tests/test_forward_belief.py). :meth:`TypeTables.of` keeps one per fitted
model (:func:`~.model_cache.per_model`), shared read-only by every synthesizer and forward belief of that model.
"""

from __future__ import annotations

import numpy as np

from ..model.affordance import AffordanceParameters
from ..model.densities import lognorm_logpdf
from ..model.potentials import reference_weights
from .model_cache import per_model
from .row_density import RowSet

__all__ = ["TypeTables"]


class TypeTables:
    """One row per (type, affordable joint) for the spatial potentials and per (type, used joint) for the
    motion potentials (``AffordanceConfig.vector_density == "polar"`` only). ``kernel``: how the row densities are
    evaluated (:class:`~.row_density.RowSet`: ``"numpy"``, the reference, or ``"numba"``, compiled)."""

    def __init__(self, model: AffordanceParameters, kernel: str = "numpy") -> None:
        S = model.n_subevents_
        cfg = model.config
        self.S, self.eps, self.kernel = S, cfg.eps, kernel
        sp_rows, sp_w, sp_joint, sp_type, mo_joint, mo_rows, mo_expon, mo_type = [], [], [], [], [], [], [], []
        for s in range(S):
            z = model._z(s)
            W = reference_weights(z, other_side=cfg.other_side_reference, include_self=cfg.reference_self)
            for j in np.flatnonzero(z > 0):
                sp_joint.append(int(j))
                sp_rows.append(model.spatial_params_[s, j])
                sp_w.append(W[j])
                sp_type.append(s)
            for j in np.flatnonzero(z >= 0):
                mo_joint.append(int(j))
                mo_rows.append(model.motion_params_[s, j])
                mo_expon.append(bool(z[j] == 0))
                mo_type.append(s)
        J = model.spatial_params_.shape[1]
        self.sp_joint = np.array(sp_joint, np.int64)
        self.sp_params = np.array(sp_rows, float).reshape(-1, 6)
        self.sp_w = np.array(sp_w, float).reshape(-1, J)
        self.sp_type = np.array(sp_type, np.int64)
        self.mo_joint = np.array(mo_joint, np.int64)
        self.mo_params = np.array(mo_rows, float).reshape(-1, 6)
        self.mo_expon = np.array(mo_expon, bool)
        self.mo_type = np.array(mo_type, np.int64)
        # Per type: its rows and the columns its reference weights read (the model reads exactly those).
        self._sp = []
        self._read = np.zeros(self.sp_w.shape, bool)  # (R, 11): the columns the row's type reads
        for s in range(S):
            rows = np.flatnonzero(self.sp_type == s)
            cols = np.flatnonzero(self.sp_w[rows].any(axis=0))
            self._sp.append((rows, cols, self.sp_w[np.ix_(rows, cols)]))
            self._read[np.ix_(rows, cols)] = True
        self.dur = np.array(model.duration_params_, float)  # a copy: made read-only with the tables
        self._cache: dict[tuple[str, int | None], RowSet] = {}
        # Per type: the columns of its rows among all rows (the same selection as types == s, made once).
        self._sp_groups = [(s, np.flatnonzero(self.sp_type == s)) for s in range(S) if np.any(self.sp_type == s)]
        self._mo_groups = [(s, np.flatnonzero(self.mo_type == s)) for s in range(S) if np.any(self.mo_type == s)]
        self._mo_joints = {s: self.mo_joint[self.mo_type == s] for s in range(S)}
        self._mo_joints[None] = self.mo_joint
        # Every row set made now, not at a type's first scoring: the tables do not change size later in a stream.
        self._rows(("spatial", None), self.sp_params, None)
        self._rows(("motion", None), self.mo_params, self.mo_expon)
        for s in range(S):
            self._rows(("spatial", s), self.sp_params, None, self._sp[s][0])
            self._rows(("motion", s), self.mo_params, self.mo_expon, self.mo_type == s)
            # A type's spatial rows then its motion rows, one row set: a re-planning scores both on the same candidates.
            sp, mo = self._cache[("spatial", s)], self._cache[("motion", s)]
            self._cache[("both", s)] = RowSet(np.concatenate([sp.params, mo.params]), np.concatenate([sp.expon, mo.expon]),
                                              self.eps, kernel)
        # Per type, what the compiled candidates' scores read (score_rows): its spatial rows' joints, their reference
        # weights and columns, its motion rows' joints, and the table of its spatial then motion rows.
        self._score_rows = [
            (self.sp_joint[self._sp[s][0]], np.ascontiguousarray(self._sp[s][2]), self._sp[s][1],
             np.ascontiguousarray(self._mo_joints[s]), self._cache[("both", s)].table) for s in range(S)
        ]
        self.log_seconds = cfg.duration_density == "log_seconds"

    @classmethod
    def of(cls, model: AffordanceParameters, kernel: str = "numpy") -> TypeTables:
        """The tables of ``model``, made once per fitted model and ``kernel`` (:func:`~.model_cache.per_model`) and
        read-only: the same arrays for every recording, so the same values as tables made per recording."""
        key = "type_tables" if kernel == "numpy" else ("type_tables", kernel)
        return per_model(model, key, lambda: cls(model, kernel))

    def score_rows(self, s: int) -> tuple[np.ndarray, ...]:
        """What the compiled scores (:func:`~.score_kernel.scores`) read of type ``s``: its spatial rows' joints (R,),
        their reference weights (R, C) of the columns (C,) the type reads, its motion rows' joints (Q,), and the table
        (:attr:`~.row_density.RowSet.table`) of its R spatial then Q motion rows (R + Q, 16)."""
        return self._score_rows[s]

    def _per_type(self, rows: np.ndarray, only: int | None, groups: list[tuple[int, np.ndarray]]) -> np.ndarray:
        """Row log-densities (N, R) summed by type → (N, S), or (N,) for type ``only``; NaN → −inf. ``groups``: each
        type's columns among the rows, as made once (``_sp_groups``, ``_mo_groups``)."""
        if only is not None:
            out = rows.sum(axis=-1)
        else:
            out = np.zeros(rows.shape[:-1] + (self.S,))
            for s, cols in groups:
                out[..., s] = rows[..., cols].sum(axis=-1)
        return np.where(np.isnan(out), -np.inf, out)

    def _rows(
        self, key: tuple[str, int | None], params: np.ndarray, expon: np.ndarray | None, sel: np.ndarray | None = None
    ) -> RowSet:
        """A set of rows (:class:`~.row_density.RowSet`: their parameters, exponential flags and every term of the
        parameters alone), the rows ``sel`` (a selection; None: all) of ``params`` (R, 6) and ``expon`` (R,) (None: none
        exponential): made once per (potential, type) (a re-planning scores every frame on a long stream); the same
        arrays the per-call selection made, so the same values."""
        rows = self._cache.get(key)
        if rows is None:
            p = params if sel is None else params[sel]
            e = np.zeros(p.shape[0], bool) if expon is None else (expon if sel is None else expon[sel])
            rows = self._cache[key] = RowSet(p, e, self.eps, self.kernel)
        return rows

    def _density(self, vecs: np.ndarray, rows: RowSet) -> np.ndarray:
        """Row log-densities (N, R) of vectors (N, R, 3) (:func:`~socialaff_sim.model.potentials.polar_rows_logpdf` of
        :func:`~socialaff_sim.model.features.polar`, by :meth:`~.row_density.RowSet.logpdf`: the same values)."""
        return rows.logpdf(vecs)

    def spatial(self, end: np.ndarray, s: int | None = None) -> np.ndarray:
        """Spatial log-potential of N configurations ``end`` (N, 11, 3): (N, S), or (N,) under type ``s``."""
        end = np.asarray(end, float)
        if s is None:  # every row at once; a NaN in a column its type reads makes the row NaN, as in the model
            refs = np.where(self._read[None, :, :, None], self.sp_w[None, :, :, None] * end[:, None], 0.0).sum(axis=2)
            offsets = end[:, self.sp_joint] - refs
            rows = self._density(offsets, self._rows(("spatial", None), self.sp_params, None))
            return self._per_type(rows, None, self._sp_groups)
        rows, cols, w = self._sp[s]
        if rows.size == 0:
            return np.zeros(end.shape[0])
        refs = np.einsum("kj,njd->nkd", w, end[:, cols])
        offsets = end[:, self.sp_joint[rows]] - refs
        dens = self._density(offsets, self._rows(("spatial", s), self.sp_params, None, rows))
        out = dens.sum(axis=-1)
        return np.where(np.isnan(out), -np.inf, out)

    def motion(self, disp: np.ndarray, s: int | None = None) -> np.ndarray:
        """Motion log-potential of N displacement sets (N, 11, 3): (N, S), or (N,) under type ``s``."""
        rows = self._density(np.asarray(disp, float)[:, self._mo_joints[s]],
                             self._rows(("motion", s), self.mo_params, self.mo_expon, None if s is None else self.mo_type == s))
        return self._per_type(rows, s, self._mo_groups)

    def spatial_motion(self, end: np.ndarray, disp: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
        """``(spatial(end, s), motion(disp, s))`` of N configurations ``end`` and displacements ``disp`` (N, 11, 3)
        under type ``s``, each (N,): the two potentials' vectors side by side, scored in one pass of their rows (the same
        elementwise arithmetic, each potential's rows summed on their own: the same values, bitwise)."""
        rows, cols, w = self._sp[s]
        R = rows.size
        moved = disp[:, self._mo_joints[s]]
        if R:
            refs = np.einsum("kj,njd->nkd", w, end[:, cols])
            moved = np.concatenate([end[:, self.sp_joint[rows]] - refs, moved], axis=1)
        dens = self._cache[("both", s)].logpdf(moved)
        mo = dens[:, R:].sum(axis=-1)
        mo = np.where(np.isnan(mo), -np.inf, mo)
        if not R:
            return np.zeros(end.shape[0]), mo
        sp = dens[:, :R].sum(axis=-1)
        return np.where(np.isnan(sp), -np.inf, sp), mo

    def duration(self, seconds: np.ndarray) -> np.ndarray:
        """(N, S) duration log-density of N interval lengths (seconds) under every type."""
        x = np.asarray(seconds, float)[:, None]
        out = lognorm_logpdf(x, self.dur[None, :, 0], self.dur[None, :, 1])
        if self.log_seconds:
            with np.errstate(divide="ignore"):
                out = out + np.log(x)
        return np.where(np.isnan(out), -np.inf, out)
