"""The balance controller's filtered estimate of the external contacts (external_force.FilteredExternal): an
exponential average per physics step, checked against its closed form, and cleared in place."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from socialaff_sim.sim.external_force import FilteredExternal


class _Fixed:
    """Stands in for ExternalForces: the same contacts at every step."""

    def __init__(self, gen: np.ndarray, pts: np.ndarray, forces: np.ndarray) -> None:
        self.vadr = np.arange(len(gen))
        self.reading = (gen, pts, forces)

    def measure(self, m, d, contacts):  # noqa: ANN001, ANN201
        return self.reading


@pytest.mark.parametrize("tau", [0.0, 0.02, 0.5])
def test_the_estimate_is_the_closed_form_exponential_average_and_clears(rng, tau: float) -> None:
    gen, pts, forces = rng.normal(size=7), rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    est = FilteredExternal(_Fixed(gen, pts, forces), tau)  # type: ignore[arg-type]
    m = SimpleNamespace(opt=SimpleNamespace(timestep=0.002))
    for k in range(1, 6):
        est.measure(m, None, None)  # type: ignore[arg-type]
        a = math.exp(-0.002 / tau) if tau > 0 else 0.0
        w = 1.0 - a ** k  # k steps from zero toward a constant reading
        np.testing.assert_allclose(est.gen, w * gen, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(est.force, w * forces.sum(axis=0), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(est.moment, w * np.cross(pts, forces).sum(axis=0), rtol=1e-12, atol=1e-15)
    held = est.gen
    est.clear()
    assert not est.gen.any() and not est.force.any() and not est.moment.any() and held is est.gen
