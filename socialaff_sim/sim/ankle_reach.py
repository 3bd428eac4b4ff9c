"""The ankles' reach: where along its heading a standing robot's centre of mass can be held by its ankles.

The support box (:mod:`~.support_box`) says where the feet's centre of pressure may lie. A robot with weak
ankles cannot use all of it: to put the centre of pressure d ahead of an ankle under a load F, the ankle's
pitch servo must exert F·d. The H1's ankles (2 × 40 N·m) hold its 507 N at most 15.8 cm ahead of their line,
short of its toes (19.5 cm ahead); released by the harness with its centre of mass beyond that, it tips until
it is caught again (docs/benchmarks.md, "The H1's outside support in the contact phases, diagnosed …").

Statics along the heading u (horizontal, the feet's forward direction; l = ẑ × u the lateral axis): foot i
carries F_i ≥ μW (ΣF_i = W, the robot's weight; μ the balance QP's ``min_foot_load``) at its centre of pressure
p_i = a_i + d_i along u, a_i its ankle, within its sole [s_lo,i, s_hi,i]. The floor's vertical force at d_i
ahead of the ankle is a moment −F_i d_i l on the foot about it, which the ankle's hinges (of axis e, acting on
the foot) balance: τ = (l·e) F_i d_i for each, within
its actuator's limits [τ_lo, τ_hi] at the current state (times κ): so F_i d_i ∈ [M_lo,i, M_hi,i]. The centre of
mass c = Σ F_i p_i / W along u then lies in an interval [c_lo, c_hi], the largest and smallest Σ(F_i a_i + x_i)
/ W over the loads and x_i = F_i d_i ∈ [max(M_lo,i, F_i (s_lo,i − a_i)), min(M_hi,i, F_i (s_hi,i − a_i))] (a
linear programme; one-dimensional in F_1 and concave (convex) piecewise linear, so its breakpoints suffice:
:func:`reach_interval`). A foot without a hinge of its own is not limited by it (the interval is the soles').
The lateral direction is left to the support box (the H1 has no ankle roll joint). The feet's own weight and
the dynamics are neglected: it is a static reach, for the harness's release decision
(``BalanceConfig.release_reach``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from .contact_qp import actuator_limits

__all__ = ["AnkleReach", "moment_range", "reach_interval", "wanted_cop"]


def wanted_cop(com: np.ndarray, velocity: np.ndarray, goal: np.ndarray, bandwidth: float, damping: float,
               height: float, gravity: float) -> np.ndarray:
    """(2,) world: the centre of pressure that gives the centre of mass at ``com`` (2,) moving at ``velocity``
    (2,) the balance controller's wanted horizontal acceleration toward ``goal`` (2,), c̈* = ω_c² (c* − c) −
    2 ζ ω_c ċ (``bandwidth`` ω_c, ``damping`` ζ), on a linear inverted pendulum of ``height`` h (m): p = c −
    c̈* h / g. The controller's centre-of-mass feedback (ω_c = 6 rad/s) is faster than the H1's pendulum
    (√(g / h) ≈ 3.2 rad/s): a centre of mass 3 cm from its goal asks for a centre of pressure 10 cm beyond it."""
    c = np.asarray(com, dtype=np.float64)
    acc = bandwidth ** 2 * (np.asarray(goal) - c) - 2.0 * damping * bandwidth * np.asarray(velocity)
    return c - acc * (height / gravity)


def moment_range(axes: np.ndarray, limits: np.ndarray, lateral: np.ndarray) -> np.ndarray:
    """(2,) [M_lo, M_hi] (N·m): the range of F·d (load times the centre of pressure's distance ahead of the
    ankle) that hinges of world axes ``axes`` (H, 3) and torque limits ``limits`` (H, 2) carry about the lateral
    axis ``lateral`` (3,) (τ = (l·e) F d for each hinge). A hinge perpendicular to it limits nothing."""
    lo, hi = -np.inf, np.inf
    for e, (t_lo, t_hi) in zip(np.asarray(axes), np.asarray(limits), strict=True):
        s = float(np.dot(lateral, e))
        if abs(s) < 1e-6:
            continue
        a, b = sorted((t_lo / s, t_hi / s))
        lo, hi = max(lo, a), min(hi, b)
    return np.array([lo, hi])


def reach_interval(weight: float, ankle: np.ndarray, sole: np.ndarray, moment: np.ndarray,
                   min_load: float = 0.0) -> np.ndarray:
    """(2,) [c_lo, c_hi] (m, along the heading): where the centre of mass can be held (module docstring).
    ``weight`` W (N); ``ankle`` (2,) each foot's ankle along the heading (m); ``sole`` (2, 2) each foot's sole
    [lo, hi] along it (m); ``moment`` (2, 2) each foot's [M_lo, M_hi] (N·m, :func:`moment_range`); each foot
    carries at least ``min_load`` W."""
    a = np.asarray(ankle, dtype=np.float64)
    s = np.asarray(sole, dtype=np.float64)
    mo = np.asarray(moment, dtype=np.float64)
    f_lo, f_hi = min_load * weight, (1.0 - min_load) * weight
    cand = [f_lo, f_hi]
    for end in (0, 1):  # the loads at which a foot's moment limit meets its sole's end
        for i in (0, 1):
            arm = s[i, end] - a[i]
            if abs(arm) > 1e-12 and np.isfinite(mo[i, end]):
                f = mo[i, end] / arm
                cand.append(f if i == 0 else weight - f)
    f1 = np.clip(np.array(cand), f_lo, f_hi)
    loads = np.stack([f1, weight - f1], axis=1)  # (K, 2)
    x_hi = np.minimum(mo[:, 1], loads * (s[:, 1] - a))
    x_lo = np.maximum(mo[:, 0], loads * (s[:, 0] - a))
    base = loads @ a
    return np.array([float((base + x_lo.sum(axis=1)).min()), float((base + x_hi.sum(axis=1)).max())]) / weight


class AnkleReach:
    """The ankles' reach of one robot's feet in a scene (module docstring)."""

    def __init__(self, m: mujoco.MjModel, feet: list[int], act_ids: np.ndarray, fraction: float,
                 soles: list[np.ndarray | None] | None = None) -> None:
        self.feet = list(feet)
        self.soles = soles if soles is not None else [None] * len(feet)
        """Each foot's sole corners (S, 3) in its body's frame (``None``: its contact points are used)."""
        self.withheld = 0
        """Physics steps in which :meth:`holds` said no (since the last :meth:`reset`)."""
        self.fraction = float(fraction)
        """κ [—]: the share of each ankle servo's limit the reach may use."""
        trn = {int(m.actuator_trnid[a, 0]): int(a) for a in np.asarray(act_ids)}
        self._joints: list[np.ndarray] = []
        self._acts: list[np.ndarray] = []
        for body in feet:
            js = [j for j in range(m.njnt) if m.jnt_bodyid[j] == body and m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
            self._joints.append(np.array(js, dtype=np.int64))
            self._acts.append(np.array([trn.get(j, -1) for j in js], dtype=np.int64))

    def interval(self, m: mujoco.MjModel, d: mujoco.MjData, forward: np.ndarray, soles: np.ndarray,
                 weight: float, min_load: float) -> np.ndarray:
        """(2,) [c_lo, c_hi] (m, along the unit heading ``forward`` (2,)) at the state ``d``: ``soles`` (2, 2)
        each foot's sole [lo, hi] along it (m); ``weight`` (N); ``min_load`` (fraction of it per foot)."""
        u = np.array([forward[0], forward[1], 0.0])
        lateral = np.cross([0.0, 0.0, 1.0], u)
        ankle = np.zeros(2)
        moment = np.tile([-np.inf, np.inf], (2, 1))
        for i, (js, acts) in enumerate(zip(self._joints, self._acts, strict=True)):
            if not len(js):
                ankle[i] = 0.5 * (soles[i, 0] + soles[i, 1])
                continue
            ankle[i] = float(d.xanchor[js].mean(axis=0)[:2] @ u[:2])
            lim = np.zeros((len(js), 2))  # a hinge without a servo carries nothing
            have = acts >= 0
            if have.any():
                q = d.qpos[m.jnt_qposadr[js[have]]]
                v = d.qvel[m.jnt_dofadr[js[have]]]
                lim[have] = actuator_limits(m, acts[have], q, v)
            moment[i] = moment_range(d.xaxis[js], self.fraction * lim, lateral)
        return reach_interval(weight, ankle, soles, moment, min_load)

    def reset(self) -> None:
        """The counter at zero."""
        self.withheld = 0

    def holds(self, m: mujoco.MjModel, d: mujoco.MjData, forward: np.ndarray, points: tuple[np.ndarray, ...],
              contacts: np.ndarray, which: np.ndarray, weight: float, min_load: float) -> bool:
        """Whether every one of ``points`` ((2,) world: the centre of mass, the capture point, the centre of
        pressure the controller would ask for, :func:`wanted_cop`) lies within the ankles' reach along
        ``forward`` (2,); ``contacts`` (P, 3) the feet's floor contacts and ``which`` (P,) their foot, for a foot
        whose sole is unknown (a foot with neither limits nothing)."""
        u = np.asarray(forward, dtype=np.float64)
        soles = np.tile([-np.inf, np.inf], (2, 1))
        for i, (body, sole) in enumerate(zip(self.feet, self.soles, strict=True)):
            xy = (contacts[which == i, :2] if sole is None
                  else (d.xpos[body] + sole @ d.xmat[body].reshape(3, 3).T)[:, :2])
            if len(xy):
                soles[i] = [float((xy @ u).min()), float((xy @ u).max())]
        if not np.isfinite(soles).all():
            return True
        lo, hi = self.interval(m, d, u, soles, weight, min_load)
        ok = all(lo <= float(np.asarray(p) @ u) <= hi for p in points)
        self.withheld += int(not ok)
        return ok
