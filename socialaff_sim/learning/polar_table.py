"""Polar coordinates of every instance's candidate intervals, kept across the hard-EM rounds of one run.

The hard-EM rounds (:mod:`.initial`) score every (start atom, end atom) interval of every instance under each
type's potentials, round after round. What a type's score reads of an interval before its parameters enter is
fixed by the interval and the type's grouping alone: the polar coordinates (h, |dz|, θ) of each affordable
joint's offset from its reference point (:func:`~socialaff_sim.model.potentials.spatial_offsets`) and of each
available joint's displacement. :class:`PolarTable` keeps them: the displacements' per instance, the offsets' per
instance and grouping for the ``keep`` most recently used groupings (a grouping often survives several rounds;
bounded memory). An entry is the very arrays :func:`~socialaff_sim.model.potentials.log_spatial` and
:func:`~socialaff_sim.model.potentials.log_motion` compute, so scores from it are bitwise theirs
(``tests/test_sample_fits.py``).
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from ..model.config import AffordanceConfig
from ..model.features import IntervalFeatures, polar
from ..model.potentials import cartesian_correction, spatial_offsets

__all__ = ["PolarTable", "Polar"]

Polar = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]
"""(h, |dz|, θ) (each (N, K)) and, with ``vector_density == "cartesian"``, the summed Jacobian term (N,) (else None)."""


class PolarTable:
    """Polar coordinates of the candidate intervals' offsets and displacements of one run (see the module doc)."""

    def __init__(self, acfg: AffordanceConfig, keep: int = 16) -> None:
        self.acfg = acfg
        self.keep = keep
        self._motion: dict[tuple[int, bytes], Polar] = {}
        self._spatial: OrderedDict[bytes, dict[int, Polar]] = OrderedDict()

    def _polar(self, vecs: np.ndarray) -> Polar:
        h, v, th = polar(vecs, self.acfg.eps)
        corr = cartesian_correction(vecs, self.acfg.eps).sum(axis=-1) if self.acfg.vector_density == "cartesian" else None
        return h, v, th, corr

    def motion(self, i: int, used: np.ndarray, feats: IntervalFeatures) -> Polar:
        """Instance ``i``'s displacements of joints ``used`` (``feats``: its intervals, the same at every call)."""
        key = (i, used.tobytes())
        hit = self._motion.get(key)
        if hit is None:
            hit = self._motion[key] = self._polar(np.asarray(feats.disp, float)[:, used])
        return hit

    def spatial(self, i: int, z: np.ndarray, feats: IntervalFeatures) -> Polar:
        """Instance ``i``'s offsets of the affordable joints of grouping ``z`` (with at least one affordable joint)."""
        zkey = z.tobytes()
        per = self._spatial.get(zkey)
        if per is None:
            per = self._spatial[zkey] = {}
            while len(self._spatial) > self.keep:
                self._spatial.popitem(last=False)
        else:
            self._spatial.move_to_end(zkey)
        hit = per.get(i)
        if hit is None:
            acfg = self.acfg
            offsets = spatial_offsets(
                z, np.asarray(feats.end, float), other_side=acfg.other_side_reference, include_self=acfg.reference_self
            )
            hit = per[i] = self._polar(offsets)
        return hit
