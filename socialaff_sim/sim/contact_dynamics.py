"""Floating-base inverse dynamics with contact forces: joint torques for wanted accelerations of a standing robot.

A robot standing on the floor obeys ``M q̈ + h = Sᵀτ + Gβ``: M (n, n) its mass matrix, h (n,) its bias
forces (Coriolis, centrifugal, gravity, minus passive forces), S selects the actuated coordinates, and the
floor pushes at the feet's contact points with forces inside linearised friction cones, each a
non-negative combination β ≥ 0 of the cone's four edges (``G = Σ_p J_pᵀ E_p``, J_p (3, n) the point's
translational Jacobian, E_p (3, 4) the edges n ± μ t₁, n ± μ t₂, normalised). The root's six coordinates
(and any unactuated hinge) have no torque: their rows of the equation bind q̈ to β.

:func:`solve_contact_dynamics` chooses (q̈, β) by weighted least squares over

* the unactuated rows of the equation of motion (a heavy weight: nearly hard), in m/s² (divided by the
  robot's mass);
* tasks ``A q̈ = b`` with their weights (the controller's: planted feet still, centre of mass, torso, joints);
* a small regularisation of β (forces in N divided by the mass),

subject to β ≥ 0. q̈ is eliminated in closed form (its rows have full column rank) and β comes from a
non-negative least-squares problem (:func:`scipy.optimize.nnls`). The torques are the actuated rows of
``M q̈ + h − Gβ``. Non-negative edge weights keep every contact force pushing (never pulling) inside its
friction cone, so the centre of pressure of a foot stays inside its contact points' hull.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

__all__ = ["ContactDynamicsResult", "cone_edges", "solve_contact_dynamics"]


@dataclass(frozen=True)
class ContactDynamicsResult:
    """The solution of one :func:`solve_contact_dynamics` call."""

    qacc: np.ndarray
    """(n,) the chosen generalised acceleration (root: m/s², rad/s²; hinges rad/s²)."""
    forces: np.ndarray
    """(P, 3) the contact force at each point, world frame, N."""
    tau: np.ndarray
    """(n,) generalised force the actuators must supply (``M q̈ + h − Gβ``; the unactuated rows are the
    residual the solution leaves there, N or N·m)."""


def cone_edges(frames: np.ndarray, mu: float) -> np.ndarray:
    """(P, 3, 4) unit edges of the linearised friction cones of contacts with frames ``frames`` (P, 3, 3) (rows:
    the normal, then two tangents, as MuJoCo's ``contact.frame``) and friction coefficient ``mu``."""
    n, t1, t2 = frames[:, 0], frames[:, 1], frames[:, 2]
    e = np.stack([n + mu * t1, n - mu * t1, n + mu * t2, n - mu * t2], axis=-1)  # (P, 3, 4)
    return e / np.linalg.norm(e, axis=1, keepdims=True)


def solve_contact_dynamics(M: np.ndarray, h: np.ndarray, unactuated: np.ndarray, point_jac: np.ndarray,
                           edges: np.ndarray, tasks: list[tuple[np.ndarray, np.ndarray, float]], mass: float,
                           w_dynamics: float, w_force: float) -> ContactDynamicsResult:
    """Accelerations, contact forces and torques of a standing robot (see the module docstring).

    ``M`` (n, n), ``h`` (n,): mass matrix and bias forces (N, N·m) of the robot's coordinates;
    ``unactuated`` (n,) bool: coordinates without an actuator (the root's six at least);
    ``point_jac`` (P, 3, n): translational Jacobians of the contact points; ``edges`` (P, 3, 4): their cones'
    edges (:func:`cone_edges`); ``tasks``: (A (r, n), b (r,), w) — the rows ``A q̈ = b`` weighted by w (each
    row's residual is in m/s² or rad/s²); ``mass`` (kg) scales forces to accelerations; ``w_dynamics``,
    ``w_force``: weights of the equation of motion's unactuated rows and of the forces' regularisation.
    """
    n = M.shape[0]
    P = point_jac.shape[0]
    G = np.einsum("pin,pik->npk", point_jac, edges).reshape(n, 4 * P)  # (n, 4P): generalised force per edge
    blocks_q, blocks_b, rhs = [], [], []
    s = np.sqrt(w_dynamics) / mass
    blocks_q.append(s * M[unactuated])
    blocks_b.append(-s * G[unactuated])
    rhs.append(-s * h[unactuated])
    for A, b, w in tasks:
        sw = np.sqrt(w)
        blocks_q.append(sw * A)
        blocks_b.append(np.zeros((A.shape[0], 4 * P)))
        rhs.append(sw * b)
    sf = np.sqrt(w_force) / mass
    blocks_q.append(np.zeros((4 * P, n)))
    blocks_b.append(sf * np.eye(4 * P))
    rhs.append(np.zeros(4 * P))
    Aq, Ab, b = np.vstack(blocks_q), np.vstack(blocks_b), np.concatenate(rhs)
    Q, R = np.linalg.qr(Aq)  # Aq (rows, n) of full column rank: q̈ = R⁻¹ Qᵀ (b − Ab β)
    if P:
        # β only: the residual orthogonal to Aq's columns, which q̈ cannot absorb.
        Pb = Ab - Q @ (Q.T @ Ab)
        Pr = b - Q @ (Q.T @ b)
        beta = nnls(Pb, Pr, maxiter=50 * 4 * P)[0]
    else:
        beta = np.zeros(0)
    qacc = np.linalg.solve(R, Q.T @ (b - Ab @ beta))
    gen = G @ beta
    tau = M @ qacc + h - gen
    forces = np.einsum("pik,pk->pi", edges, beta.reshape(P, 4)) if P else np.zeros((0, 3))
    return ContactDynamicsResult(qacc=qacc, forces=forces, tau=tau)
