"""The environment's control period: how the physics steps of a data frame are split into env steps.

A data frame lasts 1/fps s and is simulated in n physics steps (``Simulator.n_sub``). With a control
period Δt_c (``EnvConfig.control_dt``) the frame is split into m = round(1/(fps·Δt_c)) control steps
(1 ≤ m ≤ n); control step j runs the frame's physics steps ⌊j·n/m⌋ … ⌊(j+1)·n/m⌋ − 1, so every control
step covers ⌊n/m⌋ or ⌈n/m⌉ physics steps and the frame's last control step ends on the frame's end.
Without a control period (``None``) an env step is the whole frame (m = 1).

The robot's targets are for the frame's end: the IK is solved on a frame's first control step, and
again on a later control step of the same frame only when its targets differ from those last solved
(:meth:`ControlClock.needs_solve`); the servo references then go from where they are to the new
solution over the frame's remaining physics steps (``Simulator.solve``). A policy that holds its action
through a frame therefore gets exactly the physics of one env step per frame.
"""

from __future__ import annotations

import numpy as np

from .arrays import same_array

__all__ = ["ControlClock", "control_steps_per_frame"]


def control_steps_per_frame(fps: float, n_sub: int, control_dt: float | None) -> int:
    """m, the control steps per data frame of ``fps`` frames/s simulated in ``n_sub`` physics steps."""
    if control_dt is None:
        return 1
    return int(min(n_sub, max(1, round(1.0 / (fps * control_dt)))))


class ControlClock:
    """Which physics step of the frame each control step ends on, and when the IK must be solved again."""

    def __init__(self, control_dt: float | None) -> None:
        self.control_dt = control_dt
        """Δt_c [s] (``None``: one control step per frame)."""
        self.bounds: tuple[int, ...] = (1,)
        """The physics step (exclusive) each control step of a frame ends on, ascending; the last is n."""
        self.step_seconds = 0.0
        """Simulated seconds of one physics step of the current instance."""
        self._solved: np.ndarray | None = None

    def reset(self, fps: float, n_sub: int) -> None:
        """Start an instance of ``fps`` frames/s with ``n_sub`` physics steps per frame."""
        m = control_steps_per_frame(fps, n_sub, self.control_dt)
        self.bounds = tuple((j * n_sub) // m for j in range(1, m + 1))
        self.step_seconds = 1.0 / (fps * n_sub)
        self._solved = None

    @property
    def per_frame(self) -> int:
        """m, control steps per data frame."""
        return len(self.bounds)

    def end_of(self, substep: int) -> int:
        """The physics step (exclusive) the control step starting at ``substep`` of the frame ends on."""
        for b in self.bounds:
            if b > substep:
                return b
        return self.bounds[-1]

    def needs_solve(self, substep: int, targets: np.ndarray) -> bool:
        """Whether a control step starting at physics step ``substep`` of the frame, toward ``targets`` (5, 3),
        solves the IK: at the frame's start always, later only when the targets changed; remembers them."""
        if substep == 0 or self._solved is None or not same_array(targets, self._solved):
            self._solved = np.array(targets, dtype=np.float64)
            return True
        return False
