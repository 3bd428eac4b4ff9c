"""The centre of mass's reference moved forward by the feet's shortfall (``BalanceConfig.com_shift``).

In the standing mode the walk-up's feet often come down short of the plan's: the foot lock plants the plan's feet at
their targets, the physical ones stand 3–10 cm behind them along the heading (docs/benchmarks.md, "The standing
mode's high fives traced …"). The controller's ``plan`` reference carries the plan's centre of mass relative to *its*
feet onto the physical feet, so the whole body stands that much behind the plan and a raised hand stops short of the
person's. Holding the centre of mass where the plan has it in the world (``com_reference="world"`` with a heavy
``w_com``, measured and removed: docs/design.md §5) mended that, but it also pulled the body sideways after feet that
land off to the side (a pull-up's 20 cm) and, with nothing to mend, stiffened the centre of mass against every arm's
swing, which the trunk then took up (tilt, and the harness's catch). Here only the shortfall along the feet's
heading is made up, at most s_max, and the centre of mass's rows are weighted up in proportion to it:

    d = (p̄_plan − p̄) · f,   s = clip(d, 0, s_max),   c* = c*_plan + s f,   w = w_com + (w_s − w_com) s / s_max,

p̄_plan and p̄ the middles of the plan's and the physical feet (world, horizontal), f the feet's forward direction
(unit, horizontal). Feet that stand on or ahead of the plan's change nothing (s = 0, w = w_com).
"""

from __future__ import annotations

import numpy as np

__all__ = ["forward_shortfall", "shift_weight"]


def forward_shortfall(plan_feet: np.ndarray, feet: np.ndarray, forward: np.ndarray, cap: float) -> tuple[np.ndarray, float]:
    """The reference's shift (2,) (world, m) and its share of the cap, s / s_max in [0, 1]: ``plan_feet`` (2,) and
    ``feet`` (2,) the middles of the plan's and the physical feet (world, m), ``forward`` (2,) the feet's unit heading,
    ``cap`` s_max > 0 (m)."""
    d = float((np.asarray(plan_feet) - np.asarray(feet)) @ forward)
    s = min(max(d, 0.0), cap)
    return s * np.asarray(forward, dtype=float), s / cap


def shift_weight(w_com: float, w_shift: float, share: float) -> float:
    """The centre of mass's rows' weight at a shift's ``share`` of the cap in [0, 1]: w_com at none, w_s at the cap."""
    return w_com + (w_shift - w_com) * share
