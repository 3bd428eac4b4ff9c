"""The harness of the physics-rate balance controller: when it lets go of the robot, when it catches it, and how a
caught robot is led back onto the IK's base.

Decided per physics step (:class:`HarnessRelease`, owned by :class:`~.balance_control.BalanceController`): the weld
lets go once both feet have been planted ``release_delay`` and the robot is steady (the torso within
``release_tilt``, or ``release_tilt_touched`` after a touch on a robot whose feet's roll the controller frees, in a
throw (with ``release_tilt_touched_above``: a high five), the capture point inside the support box by
``release_margin`` (with ``release_front_catch`` in a throw, on the H1: that far behind its front face), and with
``release_settled`` within that of the centre of mass, with ``release_settled_raised`` only in the strike's frames:
:meth:`see_plan`); it catches the robot again at
once when the torso tilts past ``catch_tilt`` (on the H1 with ``catch_tilt_lean_roll_free``: raised by the plan's
lean), the capture point leaves the box by more than ``catch_margin``, or a
foot steps. A caught robot is held where it was caught and led onto the IK's base over ``catch_blend``, and the
release waits its delay again.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .arm_contacts import wrist_frames, wrist_positions
from .balance_config import BalanceConfig
from .scene import Scene
from .support_box import SupportBox


class HarnessRelease:
    """The harness's state and decision of one physics scene; :meth:`reset` per episode, :meth:`blend_anchor`
    before ``mj_step1`` and :meth:`decide` after it, each physics step."""

    def __init__(self, scene: Scene, config: BalanceConfig, roll_freed: bool = False) -> None:
        self.config = config
        self._tilt_touched = config.release_tilt_touched if roll_freed else None
        self.tilt_touched = self._tilt_touched
        """[deg] ``release_tilt_touched`` where it acts (a robot whose feet's roll the controller frees, in a task
        with a catch sub-goal, with ``release_tilt_touched_above`` one counted above: :meth:`gate_touched`), else
        ``None``: the release's tilt bound after a touch (:meth:`release_tilt`)."""
        self._front = config.release_front_catch if roll_freed else None
        self.front = self._front
        """[m] ``release_front_catch`` where it acts (a robot whose feet's roll the controller frees, in a task with a
        catch sub-goal: :meth:`gate_touched`), else ``None``: the capture point's least distance behind the box's
        front face for a release."""
        self._ahead = config.release_ahead_catch if roll_freed else None
        self.ahead = self._ahead
        """[m] ``release_ahead_catch`` where it acts (as :attr:`front`), else ``None``."""
        self.lean_gain = config.catch_tilt_lean_roll_free if roll_freed else None
        """[—] ``catch_tilt_lean_roll_free`` where it acts (a robot whose feet's roll the controller frees), else
        ``None``: the catch's tilt bound grows with the plan's lean (:meth:`catch_tilt`)."""
        self.settled = config.release_settled
        """[m] ``release_settled`` where it acts (:meth:`gate_settled`), else ``None``."""
        self._raised = config.release_settled_raised
        self._wrists = wrist_frames(scene) if self._raised is not None else []
        self._shoulders = scene.limb_body_ids[:2]
        self.follow = config.catch_follow_feet
        """[m] ``catch_follow_feet`` where it acts (:meth:`gate_follow`), else ``None``."""
        self._root, self._mocap = scene.root_body, scene.anchor_mocap
        self._weld = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
        self.reset()

    def reset(self) -> None:
        """A new episode: harnessed, nothing planted, counters at zero."""
        self.released = False
        """Whether the harness is off (as of the last step)."""
        self.catches = self.released_steps = 0
        """Times a released robot was caught; physics steps with the harness off."""
        self.catch_reasons = {"tilt": 0, "capture": 0, "step": 0}
        """Catches by cause: the torso's tilt, the capture point off the soles, a foot no longer planted."""
        self._engaged = 0.0  # (s) both feet planted for this long
        self._caught: tuple[np.ndarray, np.ndarray, float] | None = None  # the root's pose at the catch, time since
        self.strike = self._raised is None
        """Whether :attr:`settled` acts in this data frame (``release_settled_raised``: :meth:`see_plan`; without
        it, always)."""
        self.feet_offset = np.zeros(2)
        """(2,) m: the planted feet's mean horizontal offset from their targets, set by the simulator each data frame
        (``catch_follow_feet``; zero beyond d_m of a meeting)."""

    @property
    def holds_caught(self) -> bool:
        """Whether the harness holds a robot it has caught (a catch in this episode, for any cause, and not let go
        since; as of the last step)."""
        return self.catches > 0 and not self.released

    def blend_anchor(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        """After a catch: the harness's anchor (which the stepper has set to the IK's base for this step) moved
        from the root's pose at the catch onto it over ``catch_blend``; with ``catch_follow_feet`` the IK's base
        shifted by :attr:`feet_offset` while the robot is held caught."""
        if self.follow is not None and self.holds_caught and self._mocap >= 0:  # over the feet as they stand
            d.mocap_pos[self._mocap, :2] += self.feet_offset
        if self._caught is None or self.released or self._mocap < 0:
            self._caught = None
            return
        pos, quat, t = self._caught
        a = min(t / self.config.catch_blend, 1.0) if self.config.catch_blend > 0 else 1.0
        if a >= 1.0:
            self._caught = None
            return
        k = self._mocap
        d.mocap_pos[k] = (1.0 - a) * pos + a * d.mocap_pos[k]
        q = d.mocap_quat[k]
        q = (1.0 - a) * quat + a * (q if float(q @ quat) >= 0 else -q)
        d.mocap_quat[k] = q / np.linalg.norm(q)
        self._caught = (pos, quat, t + m.opt.timestep)

    def gate_touched(self, catch: bool, above: bool = False) -> None:
        """``release_tilt_touched`` only in a task with a ``catch`` sub-goal (``catch``: an object thrown to the
        robot), or with ``release_tilt_touched_above`` only in a task with a contact counted ``above`` the shoulders
        (the high five); ``release_front_catch`` and ``release_ahead_catch`` only in a task with a ``catch`` sub-goal;
        elsewhere :attr:`tilt_touched`, :attr:`front` and :attr:`ahead` are ``None``. Called by the simulator at each
        episode's start."""
        keep = above if self.config.release_tilt_touched_above else catch
        self.tilt_touched = self._tilt_touched if keep else None
        self.front = self._front if catch else None
        self.ahead = self._ahead if catch else None

    def gate_follow(self, chair: bool) -> None:
        """``catch_follow_chair``: ``catch_follow_feet`` only in a task whose person sits on a ``chair`` at the start
        (the pull-up); elsewhere :attr:`follow` is ``None``. Called by the simulator at each episode's start."""
        c = self.config
        self.follow = c.catch_follow_feet if chair or not c.catch_follow_chair else None

    def gate_settled(self, above: bool, causal: bool) -> None:
        """``release_settled_above``: ``release_settled`` only in a task with a contact counted ``above`` the
        shoulders; ``release_settled_causal_only``: only in an episode driven by a ``causal`` synthesis; elsewhere
        :attr:`settled` is ``None``. Called by the simulator at each episode's start."""
        c = self.config
        keep = (above or not c.release_settled_above) and (causal or not c.release_settled_causal_only)
        self.settled = c.release_settled if keep else None

    def see_plan(self, plan: mujoco.MjData) -> None:
        """The IK's plan at a data frame's end (after ``mj_kinematics``): with ``release_settled_raised`` h_s,
        :attr:`strike` is whether it holds a wrist at least h_s above that arm's shoulder (with
        ``release_settled_latch``: whether any plan since :meth:`reset` has). Called by the controller per frame."""
        if self._raised is None:
            return
        lift = wrist_positions(plan, self._wrists)[:, 2] - plan.xpos[self._shoulders, 2]
        raised = bool((lift >= self._raised).any())
        self.strike = raised or (self.config.release_settled_latch and self.strike)

    def still(self, capture: np.ndarray, com: np.ndarray) -> bool:
        """Whether the capture point (2,) lies within :attr:`settled` of the centre of mass (2,) (world, m)."""
        dx, dy = float(capture[0] - com[0]), float(capture[1] - com[1])
        return dx * dx + dy * dy <= self.settled * self.settled  # type: ignore[operator]

    def release_tilt(self, touched: bool) -> float:
        """[deg] The torso's tilt up to which the harness lets go: ``release_tilt``, or after an arm's first
        touch (``touched``) :attr:`tilt_touched` where set."""
        return self.tilt_touched if touched and self.tilt_touched is not None else self.config.release_tilt

    def catch_tilt(self, plan_lean: float) -> float:
        """[deg] The torso's tilt past which a released robot is caught: ``catch_tilt``, plus :attr:`lean_gain`
        times the plan's torso lean from upright ``plan_lean`` (deg) where set."""
        c = self.config
        return c.catch_tilt if self.lean_gain is None else c.catch_tilt + self.lean_gain * max(plan_lean, 0.0)

    def decide(self, d: mujoco.MjData, dt: float, standing: bool, tilt: float, box: SupportBox | None,
               capture: np.ndarray, touched: bool = False, com: np.ndarray | None = None,
               plan_lean: float = 0.0) -> None:
        """The step's decision after ``mj_step1``: ``standing`` (both feet planted and on the floor), the torso's
        ``tilt`` (degrees), the support ``box`` (``None`` unless standing) and the ``capture`` point (2,) (world, m);
        ``dt`` (s) the physics step; ``touched``: an arm has touched the person or the object (:meth:`release_tilt`);
        ``com`` (2,) the centre of mass (world, m; needed with :attr:`settled` while standing); ``plan_lean`` (deg)
        the plan's torso lean from upright (:meth:`catch_tilt`).
        Switches the weld in ``d`` (with ``release``) and counts."""
        c = self.config
        catch_tilt = self.catch_tilt(plan_lean)
        self._engaged = self._engaged + dt if standing else 0.0
        was = self.released
        if not standing:
            self.released = False
        elif self.released:
            self.released = tilt <= catch_tilt and box.inside(capture, -c.catch_margin)  # type: ignore[union-attr]
        else:
            self.released = (c.release and self._engaged >= c.release_delay - 1e-9 and tilt <= self.release_tilt(touched)
                             and box.inside(capture, c.release_margin)  # type: ignore[union-attr]
                             and (self.settled is None or not self.strike or (touched and c.release_settled_until_touch)
                                  or self.still(capture, com))  # type: ignore[arg-type]
                             and (self.front is None or box.behind_front(capture) >= self.front  # type: ignore[union-attr]
                                  or box.hi[0] - box.lo[0] < c.release_front_long)  # type: ignore[union-attr]
                             and (self.ahead is None or box.R[0] @ (capture - com) <= self.ahead))  # type: ignore[union-attr, operator]
        if was and not self.released:
            self.catches += 1
            self.catch_reasons["step" if not standing else "tilt" if tilt > catch_tilt else "capture"] += 1
            self._engaged = 0.0  # caught: the release waits its delay again
            self._caught = (d.xpos[self._root].copy(), d.xquat[self._root].copy(), 0.0)
        if self._weld >= 0 and c.release:
            d.eq_active[self._weld] = 0 if self.released else 1
        self.released_steps += int(self.released)


def planted_offset(physical: np.ndarray, targets: np.ndarray, standing: tuple[bool, bool]) -> np.ndarray:
    """(2,) m: the mean horizontal offset of the planted feet's physical ankle frames ``physical`` (2, 3) from their
    ankle targets ``targets`` (2, 3) (world, m), over the feet ``standing`` (left, right) marks planted; zero when
    neither is (``catch_follow_feet``)."""
    idx = [s for s in (0, 1) if standing[s]]
    if not idx:
        return np.zeros(2)
    return np.mean(np.asarray(physical, dtype=np.float64)[idx, :2] - np.asarray(targets, dtype=np.float64)[idx, :2],
                   axis=0)
