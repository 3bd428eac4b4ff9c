"""Floating-base inverse dynamics as a quadratic program: the same problem as :mod:`~.contact_dynamics`, with the
equation of motion, the torque limits and the feet's centres of pressure as hard constraints.

The decision variables are the robot's accelerations q̈ (n,) and the edge weights β (4P,) of the feet's
linearised friction cones (:func:`~.contact_dynamics.cone_edges`; forces f_p = E_p β_p), scaled by the robot's
mass (β' = β / m, in m/s²) so that every row of the problem is an acceleration. :func:`solve_contact_qp`
minimises

    Σ_k w_k ‖A_k q̈ − b_k‖² + w_f ‖β'‖² + ε ‖q̈‖²

(the tasks as in the least-squares solve, a small regularisation of the forces and of q̈; optionally a further cost
on the forces, ``force_cost``: the feet's shear beyond the net, :mod:`~.shear_spread`) subject to

* the unactuated rows of ``M q̈ + h = Sᵀτ + Gβ`` (the root's six; equalities);
* β ≥ 0: every contact force pushes and stays inside its friction pyramid;
* τ_lo ≤ (M q̈ + h − Gβ)_a ≤ τ_hi on the actuated rows: the actuators' real limits (:func:`actuator_limits`);
* optionally, hard task rows ``A q̈ = b`` (a planted foot held flat, :mod:`~.flat_feet`);
* optionally, hard inequality rows ``A q̈ ≥ lo`` (the arms kept clear of the body, :mod:`~.self_clearance`);
* optionally, each foot's vertical force at least a minimum load;
* each foot's centre of pressure inside an interval per horizontal axis (:func:`cop_rows`), the sole shrunk by a
  margin: ``Σ_i f_z,i (r_i − lo) ≥ 0`` and ``Σ_i f_z,i (hi − r_i) ≥ 0`` over the foot's points.

Any β ≥ 0 with q̈ = M⁻¹(Gβ − h) (τ = 0) satisfies the equation of motion and the torque limits (where they
include 0), and β = 0 the centre-of-pressure rows, so the problem is feasible (with a minimum load: any β that
carries it on each foot with its centre of pressure in bounds). It is solved by DAQP
(:func:`daqp.solve`, the dual active-set solver mink uses), dense, with the bounds on β as simple bounds.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import cached_property, lru_cache

import daqp
import mujoco
import numpy as np

from .._norms import norms
from .qp_kernel import compiled_rows

__all__ = ["ActuatorLimits", "ContactQPResult", "actuator_limits", "cop_rows", "solve_contact_qp"]

log = logging.getLogger(__name__)

_INF = 1e30


@dataclass(frozen=True)
class ContactQPResult:
    """The solution of one :func:`solve_contact_qp` call."""

    qacc: np.ndarray
    """(n,) the chosen generalised acceleration (root: m/s², rad/s²; hinges rad/s²)."""
    beta: np.ndarray
    """(4P,) the cone edges' weights, N (f_p = E_p β_p)."""
    tau: np.ndarray
    """(n,) generalised force the actuators must supply, ``M q̈ + h − Gβ`` (≈ 0 on the unactuated rows)."""
    at_limit: np.ndarray
    """(n,) bool: actuated rows whose torque lies on a bound of its limit (the limit constraint is active)."""
    found: bool
    """Whether DAQP reported an optimal solution (``False``: free fall is returned, see :func:`solve_contact_qp`)."""
    relaxed: bool
    """Whether the hard task rows, foot loads and centre-of-pressure bounds were dropped because they could not
    hold together."""
    inequalities_dropped: bool = False
    """Whether the hard inequality rows were dropped too (they could not hold with the torque limits alone)."""
    optional_dropped: bool = False
    """Whether the first solve failed and the hard task rows marked optional were dropped (the rest held; with
    ``relaxed`` False)."""
    edges: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 4)), repr=False)
    """(P, 3, 4) the cone edges β weighs (the solve's ``edges``)."""

    @cached_property
    def forces(self) -> np.ndarray:
        """(P, 3) the contact force at each point, world frame, N: ``f_p = E_p β_p`` (worked out when first read: the
        balance controller, called at every physics step, needs only the torques)."""
        P = len(self.edges)
        return np.einsum("pik,pk->pi", self.edges, self.beta.reshape(P, 4)) if P else np.zeros((0, 3))


def actuator_limits(m: mujoco.MjModel, act_ids: np.ndarray, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
    """(A, 2) lowest and highest force (N or N·m) each actuator ``act_ids`` (A,) can deliver to its joint at the
    state ``qpos`` and ``qvel`` (A,) of the joint, clipped as MuJoCo clips: where the control is limited, the
    force ``gain·ctrl + b₀ + b₁q + b₂q̇`` at the ends of ``ctrlrange`` (a position servo's reach at this state),
    then clipped to its ``forcerange`` (where force-limited), then to its joint's ``actuatorfrcrange`` (where
    limited; one actuator per joint, gear 1, as the scenes' robots have). ±inf where nothing limits it. One call of
    :class:`ActuatorLimits`, which gathers the model's constants for repeated calls."""
    return ActuatorLimits(m, act_ids)(qpos, qvel)


class ActuatorLimits:
    """:func:`actuator_limits` of the actuators ``act_ids`` (A,) of one model, its constants (gains, biases, ranges,
    which limits apply) gathered once: called at every physics step the balance controller drives, with none of
    the per-call indexing."""

    def __init__(self, m: mujoco.MjModel, act_ids: np.ndarray) -> None:
        ids = np.asarray(act_ids, dtype=np.int64)
        self._n = len(ids)
        self._cl = m.actuator_ctrllimited[ids].astype(bool)
        self._any_cl = bool(self._cl.any())
        self._gain = m.actuator_gainprm[ids, 0][:, None].copy()
        b = m.actuator_biasprm[ids, :3]
        self._b0, self._b1, self._b2 = b[:, 0].copy(), b[:, 1].copy(), b[:, 2].copy()
        self._ctrlrange = m.actuator_ctrlrange[ids].copy()
        self._clips = []
        for limited, rng in ((m.actuator_forcelimited[ids].astype(bool), m.actuator_forcerange[ids]),
                             (m.jnt_actfrclimited[m.actuator_trnid[ids, 0]].astype(bool),
                              m.jnt_actfrcrange[m.actuator_trnid[ids, 0]])):
            if limited.any():  # (an empty mask changes nothing)
                self._clips.append((limited, rng[limited, :1].copy(), rng[limited, 1:].copy()))

    def bounds(self, qpos: np.ndarray, qvel: np.ndarray, rows: np.ndarray, n: int, fraction: float) -> np.ndarray:
        """(n, 2) a QP's torque bounds: ``fraction`` times :meth:`__call__` at ``qpos``, ``qvel`` on the actuators'
        ``rows`` (A,) of ``n``, ±inf on the others."""
        out = np.full((n, 2), [-np.inf, np.inf])
        out[rows] = fraction * self(qpos, qvel)
        return out

    def __call__(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """(A, 2) :func:`actuator_limits` at the joints' state ``qpos``, ``qvel`` (A,)."""
        out = np.empty((self._n, 2))
        out[:, 0], out[:, 1] = -np.inf, np.inf
        if self._any_cl:
            ends = self._gain * self._ctrlrange + (self._b0 + self._b1 * qpos + self._b2 * qvel)[:, None]
            out[self._cl] = np.sort(ends, axis=1)[self._cl]
        for limited, lo, hi in self._clips:
            out[limited] = np.clip(out[limited], lo, hi)
        return out


def cop_rows(points: np.ndarray, edges: np.ndarray, foot: np.ndarray, axes: np.ndarray,
             bounds: np.ndarray) -> np.ndarray:
    """(R, 4P) rows C with ``C β ≥ 0`` iff every foot's centre of pressure lies inside its bounds (or it carries
    nothing): ``points`` (P, 3) the contact points (on the floor, z up), ``edges`` (P, 3, 4) their cones' edges,
    ``foot`` (P,) each point's foot index, ``axes`` (2, 2) the horizontal unit axes the bounds are along (world),
    ``bounds`` (F, 2, 2) per foot and axis the interval [lo, hi] (m, along the axis) for the centre of pressure.
    Two rows per foot and axis: ``Σ_i f_z,i (a·r_i − lo) ≥ 0`` and ``Σ_i f_z,i (hi − a·r_i) ≥ 0``."""
    P = len(points)
    fz = edges[:, 2, :]  # (P, 4): the vertical force of each edge per unit weight
    coord = points[:, :2] @ np.asarray(axes).T  # (P, 2)
    foot = np.asarray(foot)
    feet = np.flatnonzero(np.bincount(foot[foot >= 0], minlength=len(bounds)))  # the feet with points, in order
    if not len(feet):
        return np.zeros((0, 4 * P))
    b = np.asarray(bounds)[np.where(foot >= 0, foot, 0)]  # (P, 2, 2) each point's own foot's bounds
    # each point's four lever arms, in row order: axis 0 (r − lo, hi − r), then axis 1
    arms = np.stack([coord[:, 0] - b[:, 0, 0], b[:, 0, 1] - coord[:, 0],
                     coord[:, 1] - b[:, 1, 0], b[:, 1, 1] - coord[:, 1]])  # (4, P)
    r = np.zeros((len(feet), P, 4, 4))  # (foot, point, row, edge); a foot's rows are zero off its own points
    k, p = np.nonzero(foot[None, :] == feet[:, None])
    r[k, p] = arms[:, p].T[:, :, None] * fz[p][:, None, :]
    return r.transpose(0, 2, 1, 3).reshape(4 * len(feet), 4 * P)


def solve_contact_qp(M: np.ndarray, h: np.ndarray, unactuated: np.ndarray, point_jac: np.ndarray,
                     edges: np.ndarray, tasks: list[tuple[np.ndarray, np.ndarray, float]], mass: float,
                     w_force: float, tau_limits: np.ndarray, cop: np.ndarray | None = None,
                     foot: np.ndarray | None = None, min_load: float = 0.0, w_reg: float = 1e-6,
                     equalities: tuple[np.ndarray, np.ndarray] | None = None,
                     inequalities: tuple[np.ndarray, np.ndarray] | None = None,
                     optional: np.ndarray | None = None, kernel: str = "numpy",
                     force_cost: np.ndarray | None = None) -> ContactQPResult:
    """Accelerations, contact forces and torques of a standing robot under hard constraints (module docstring).

    ``M`` (n, n), ``h`` (n,): mass matrix and bias forces (N, N·m); ``unactuated`` (n,) bool: coordinates
    without an actuator (their rows are equalities); ``point_jac`` (P, 3, n), ``edges`` (P, 3, 4): the contact
    points' translational Jacobians and cone edges; ``tasks``: (A (r, n), b (r,), w) rows ``A q̈ = b`` with their
    weights (A (n,), b (n,): the diagonal rows ``A_i q̈_i = b_i``, one per coordinate, a zero A_i none); ``mass`` (kg); ``w_force``: weight of ‖β / m‖²; ``tau_limits`` (n, 2): [lo, hi] per row (N, N·m;
    ±inf: none; the unactuated rows' are ignored); ``cop`` (R, 4P): rows with ``cop β ≥ 0`` (:func:`cop_rows`);
    ``foot`` (P,) each point's foot (−1: none) and ``min_load`` (N): every foot with points pushes on the floor
    with at least this vertical force (a foot left without load lifts off the floor and loses its contacts);
    ``equalities``: (A (r, n), b (r,)) rows ``A q̈ = b`` that must hold exactly (m/s², rad/s²); should the
    equalities, the loads and the centre-of-pressure rows not hold together, the problem is solved again without
    the equalities, then without all three (``relaxed``); ``optional`` (r,) bool: equality rows that go first, before
    those relaxations: the problem is solved again without them (``optional_dropped``), and only if that fails too
    the relaxations follow; ``inequalities``: (A (r, n), lo (r,)) rows ``A q̈ ≥ lo``
    that must hold (m/s²), kept through both of those relaxations and dropped last, when they cannot hold with the
    root's rows and the torque limits alone (``inequalities_dropped``); ``w_reg``: ε, the regularisation of q̈;
    ``force_cost`` (4P, 4P): a further quadratic cost ½ β'ᵀ W β' on the scaled cone weights, added to the cost's
    force block (symmetric, positive semidefinite; :mod:`~.shear_spread`). Should DAQP fail (it should not: free fall is
    feasible), the result is free fall (β = 0, τ = 0, ``found=False``) and a warning is logged.
    """
    n = M.shape[0]
    P = point_jac.shape[0]
    K = 4 * P
    act, order, nu = _rows_order(np.asarray(unactuated, dtype=bool).tobytes())
    lim = np.asarray(tau_limits, dtype=np.float64)
    # The rows of the constraints, in one array: the equation of motion divided by m (M/m q̈ − G β' + h/m = τ/m), its
    # unactuated rows (equalities), then its actuated ones (the torque limits), [the inequality rows], the base;
    # then the optional ones, which the relaxations below drop: [the hard task rows], [the foot loads], [the
    # centre-of-pressure rows].
    has_eq = equalities is not None and len(equalities[1]) > 0
    has_ineq = inequalities is not None and len(inequalities[1]) > 0
    n_in = len(inequalities[1]) if inequalities is not None and has_ineq else 0
    n_eq = len(equalities[1]) if equalities is not None and has_eq else 0
    loaded = (np.flatnonzero(np.bincount(foot[foot >= 0], minlength=1)) if foot is not None and min_load > 0.0 and P
              else np.zeros(0, dtype=np.int64))  # the feet with points, in order
    n_cop = len(cop) if cop is not None else 0
    base = n + n_in
    R = base + n_eq + len(loaded) + n_cop
    rows = (M, h, order, nu, point_jac, edges, tasks, w_force, w_reg, mass, lim, inequalities if has_ineq else None,
            equalities if has_eq else None, loaded, foot, min_load, cop)
    if kernel == "numba":  # one compiled loop (:mod:`~.qp_kernel`), and DAQP on its scaled rows
        H, f, G, A_all, up, lo, sn, first = compiled_rows(*rows, force_cost)
        x, flag = first if first is not None else _daqp(H, f, K, A_all, up, lo, sn)
    else:
        H, f, G, A_all, up, lo, sn = _numpy_rows(*rows, R)
        if force_cost is not None:
            H[:K, :K] += force_cost
        x, flag = _daqp(H, f, K, A_all, up, lo, sn)
    optional_dropped = False
    if flag <= 0 and has_eq and optional is not None and np.any(optional):  # without the optional hard rows only
        log.debug("balance QP: exit flag %d; solved again without the optional hard task rows", flag)
        keep = np.ones(R, dtype=bool)
        keep[base:base + n_eq] = ~np.asarray(optional, dtype=bool)
        x, flag = _daqp(H, f, K, A_all[keep], up[keep], lo[keep], sn[keep])
        optional_dropped = flag > 0
    relaxed = flag <= 0 and R > base
    if relaxed and has_eq and R > base + n_eq:  # first without the hard task rows only
        log.debug("balance QP: exit flag %d; solved again without the hard task rows", flag)
        keep = np.ones(R, dtype=bool)
        keep[base:base + n_eq] = False
        x, flag = _daqp(H, f, K, A_all[keep], up[keep], lo[keep], sn[keep])
    if relaxed and flag <= 0:  # the equalities, minimum loads and centre-of-pressure bounds cannot hold together
        log.debug("balance QP: exit flag %d; solved again without the hard task rows, foot loads and "
                  "centre-of-pressure bounds", flag)
        x, flag = _daqp(H, f, K, A_all[:base], up[:base], lo[:base], sn[:base])
    dropped = False
    if flag <= 0 and has_ineq:  # the inequality rows cannot hold with the torque limits: the root's rows alone
        log.debug("balance QP: exit flag %d; solved again without the inequality rows", flag)
        dropped = True
        x, flag = _daqp(H, f, K, A_all[:n], up[:n], lo[:n], sn[:n])
    found = flag > 0
    if not found:
        log.warning("balance QP: DAQP exit flag %d; free fall returned", flag)
        beta = np.zeros(K)
        qacc = np.linalg.solve(M, -h)
        tau = np.zeros(n)
    else:
        beta = mass * np.maximum(np.asarray(x[:K]), 0.0)
        qacc = np.asarray(x[K:], dtype=np.float64)
        tau = M @ qacc + h - G @ beta
    tol = 1e-6 * max(1.0, mass)
    at_limit = act & ((tau >= lim[:, 1] - tol) | (tau <= lim[:, 0] + tol))
    return ContactQPResult(qacc=qacc, beta=beta, tau=tau, at_limit=at_limit, found=found, relaxed=relaxed,
                           inequalities_dropped=dropped, edges=edges, optional_dropped=optional_dropped)


def _numpy_rows(M: np.ndarray, h: np.ndarray, order: np.ndarray, nu: int, point_jac: np.ndarray, edges: np.ndarray,
                tasks: list[tuple[np.ndarray, np.ndarray, float]], w_force: float, w_reg: float, mass: float,
                lim: np.ndarray, inequalities: tuple[np.ndarray, np.ndarray] | None,
                equalities: tuple[np.ndarray, np.ndarray] | None, loaded: np.ndarray, foot: np.ndarray | None,
                min_load: float, cop: np.ndarray | None, R: int) -> tuple[np.ndarray, ...]:
    """:func:`solve_contact_qp`'s cost H (N, N), f (N,), G (n, 4P) and constraint rows A (R, N), up, lo (R,) and
    senses (R,), unscaled, with NumPy (the reference; ``qp_kernel="numba"``: :mod:`~.qp_kernel`)."""
    n = M.shape[0]
    K = 4 * point_jac.shape[0]
    G = np.einsum("pin,pik->npk", point_jac, edges).reshape(n, K)  # (n, 4P): generalised force per edge
    # Variables x = [β' (K), q̈ (n)], β' = β / m: every row is then in m/s².
    N = K + n
    H = np.zeros((N, N))
    f = np.zeros(N)
    H.flat[:K * (N + 1):N + 1] = w_force  # w_f I on β', ε I on q̈: set on the diagonal (the rest is zero as it was)
    H.flat[K * (N + 1)::N + 1] = w_reg
    Hq = H[K:, K:]
    for A, b, w in tasks:
        if A.ndim == 1:  # a diagonal task: AᵀA and Aᵀb without the products of zeros (the same sums)
            H.flat[K * (N + 1)::N + 1] += w * (A * A)  # (q̈'s diagonal)
            f[K:] -= w * (A * b)
            continue
        Hq += w * (A.T @ A)
        f[K:] -= w * (A.T @ b)
    base = n + (len(inequalities[1]) if inequalities is not None else 0)
    A_all, up, lo, sn = np.zeros((R, K + n)), np.empty(R), np.empty(R), np.zeros(R, dtype=np.intc)
    A_all[:n, :K] = -G[order]
    A_all[:n, K:] = M[order] / mass
    hm = h[order] / mass
    up[:nu] = lo[:nu] = -hm[:nu]
    sn[:nu] = 5
    la = lim[order[nu:]]
    up[nu:n] = np.where(np.isfinite(la[:, 1]), la[:, 1] / mass - hm[nu:], _INF)
    lo[nu:n] = np.where(np.isfinite(la[:, 0]), la[:, 0] / mass - hm[nu:], -_INF)
    if inequalities is not None:
        A_all[n:base, K:] = inequalities[0]
        up[n:base], lo[n:base] = _INF, inequalities[1]
    r = base
    if equalities is not None:
        n_eq = len(equalities[1])
        A_all[r:r + n_eq, K:] = equalities[0]
        up[r:r + n_eq] = lo[r:r + n_eq] = equalities[1]
        sn[r:r + n_eq] = 5
        r += n_eq
    if len(loaded):
        A_all[r:r + len(loaded), :K] = np.where(foot[None, :, None] == loaded[:, None, None],  # type: ignore[index]
                                                edges[None, :, 2, :], 0.0).reshape(len(loaded), K)
        up[r:r + len(loaded)], lo[r:r + len(loaded)] = _INF, min_load / mass
        r += len(loaded)
    if cop is not None and len(cop):
        A_all[r:, :K] = cop
        up[r:], lo[r:] = _INF, 0.0
    return np.ascontiguousarray(H), f, G, A_all, up, lo, sn


@lru_cache(maxsize=8)
def _rows_order(unactuated: bytes) -> tuple[np.ndarray, np.ndarray, int]:
    """Of the bool mask ``unactuated`` (its bytes): the actuated rows (n,) bool, the rows' order (unactuated first,
    then actuated, each ascending) and the unactuated rows' count; read-only arrays, made once per mask."""
    act = ~np.frombuffer(unactuated, dtype=bool)
    order = np.concatenate([np.flatnonzero(~act), np.flatnonzero(act)])
    act.flags.writeable = order.flags.writeable = False
    return act, order, len(act) - int(act.sum())


def _daqp(H: np.ndarray, f: np.ndarray, K: int, A_all: np.ndarray, up: np.ndarray, lo: np.ndarray,
          sn: np.ndarray) -> tuple[np.ndarray, int]:
    """DAQP on ``½xᵀHx + fᵀx`` with ``0 ≤ x[:K]`` and ``lo ≤ A_all x ≤ up`` (``A_all`` C-ordered; sense ``sn`` 5:
    equality); the rows are scaled to unit norm and empty ones dropped (with them DAQP declared feasible problems
    infeasible)."""
    norm = norms(A_all, axis=1)
    keep = norm > 1e-9
    if not keep.all():  # (most solves keep every row: no copies then)
        norm, A_all, up, lo, sn = norm[keep], A_all[keep], up[keep], lo[keep], sn[keep]
    k = 1.0 / norm
    A_all = A_all * k[:, None]  # (C-ordered, as its product)
    r = len(k)
    bu, bl, s = np.empty(K + r), np.zeros(K + r), np.zeros(K + r, dtype=np.intc)
    bu[:K] = _INF  # the first K entries: simple bounds 0 ≤ β'
    bu[K:] = np.where(up < _INF, up * k, _INF)
    bl[K:] = np.where(lo > -_INF, lo * k, -_INF)
    s[K:] = sn
    x, _, flag, _ = daqp.solve(H, f, A_all, bu, bl, s)
    return np.asarray(x), int(flag)
