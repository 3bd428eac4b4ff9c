"""Physics scoring of a task's sub-goals and failure conditions from MuJoCo contacts.

:class:`SubgoalScorer` reads ``data.contact`` after every physics step:

* ``contact`` sub-goals accumulate the time during which any geom of the robot
  group touches any geom of the human group (contact distance ≤ 0); success when
  the total reaches ``min_duration``; with ``above = "robot_shoulders"`` only
  contacts whose point is at or above the mean height of the robot's two
  shoulder bodies at that step count (toward the total and toward ``current``);
* ``catch``: after the release, a robot-hand contact with the object that comes
  before any object-floor contact;
* for both object sub-goals, a hand of the group whose grip weld holds the
  object counts as touching it (the weld keeps the object at its pose of first
  contact, which need not remain a touching contact);
* ``object_in_hand``: judged at the end: the person has let go, the object touched
  a robot hand without a break longer than :data:`GAP` over at least the last
  ``min_duration`` s (a hold that began while both held it counts) and never
  touched the floor after the release;
* failures: robot self-penetration deeper than the threshold, a total normal
  force of the robot on the human (from ``mj_contactForce``, smoothed over
  :data:`FORCE_TIME_CONSTANT`) above the threshold, the object touching the
  floor after the release.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from .._norms import norms
from .scene import Scene
from .tasks import TaskSpec

__all__ = ["SubgoalResult", "FailureResult", "SubgoalScorer", "GAP", "GAP_RANGE"]

GAP = 0.1
"""Longest break (s) in a contact that still counts as continuous holding."""
GAP_RANGE = 1.0
"""Farthest distance (m) :meth:`SubgoalScorer.measure_gaps` resolves; beyond it a gap reads ``None``."""
FORCE_TIME_CONSTANT = 0.05
"""τ (s) of the exponential moving average applied to the force on the human before the
``contact_force`` test, so that a single stiff physics step does not count as a push."""


@dataclass
class SubgoalResult:
    """State of one sub-goal."""

    name: str
    kind: str
    success: bool = False
    time: float | None = None
    """Simulated time (s) at which the sub-goal was met (for ``object_in_hand``: start of the final hold)."""
    contact_time: float = 0.0
    """Seconds of qualifying contact so far."""
    current: bool = False
    """Whether the sub-goal's contact holds *now* (at the last physics step): the robot group touches the
    human group (or the object, or holds it by its grip weld). Unlike :attr:`success`, never latched."""
    pending: bool = False
    """Whether the sub-goal is judged only at the episode's end and has not been judged yet (``object_in_hand``
    before :meth:`SubgoalScorer.finish`): its :attr:`success` is then not yet known, not false."""
    low: bool = False
    """Whether, at the last physics step, the groups touch but only below the sub-goal's height condition
    (``above``): such a touch is not :attr:`current` and does not count."""
    first_touch: float | None = None
    """Simulated time (s) of the first physics step at which the sub-goal's groups touched (at any height and in
    any sub-event; for object sub-goals a grip counts), ``None``: never. For the episode's outcome code."""
    last_touch: float | None = None
    """Simulated time (s) of the last such physics step so far (``None``: never)."""
    gap: float | None = None
    """Distance (m) between the robot group's and the other group's geoms at the last
    :meth:`SubgoalScorer.measure_gaps` (negative: penetration; ``None`` before the first, or farther
    than :data:`GAP_RANGE`)."""

    @property
    def achieved(self) -> bool:
        """Whether the sub-goal was ever met in this episode (latched; same as :attr:`success`)."""
        return self.success

    def state_text(self) -> str:
        """``"hands_clasped: now touching | achieved at 2.80 s"``: the contact now and whether it was ever met."""
        if self.current:
            now = "now touching"
        elif self.low:
            now = "now touching below the robot's shoulders"
        elif self.gap is not None:
            # Under 1 mm, "0.0 cm" reads as a touch; the contact test (distance ≤ 0 at the last step) said no.
            now = "now apart (< 1 mm)" if self.gap < 0.001 else f"now apart ({100 * self.gap:.1f} cm)"
        else:
            now = "now apart"
        if self.pending:
            ever = "judged at the end"
        else:
            ever = f"achieved at {self.time:.2f} s" if self.success and self.time is not None else (
                "achieved" if self.success else "not achieved")
        return f"{self.name}: {now} | {ever}"


@dataclass
class FailureResult:
    """State of one failure condition."""

    kind: str
    threshold: float
    triggered: bool = False
    time: float | None = None
    """Simulated time (s) of the first violation."""
    worst: float = 0.0
    """Largest value seen (metres of penetration, newtons, or 1 for a drop)."""


@dataclass
class _Tracks:
    released: bool = False
    release_time: float | None = None
    floor_time: float | None = None
    hold_since: dict[str, float | None] = field(default_factory=dict)
    last_hold: dict[str, float] = field(default_factory=dict)


def _robot_masks(scene: Scene) -> dict[str, np.ndarray]:
    hands = scene.hand_geom
    collide = scene.robot_geom & ((scene.model.geom_contype != 0) | (scene.model.geom_conaffinity != 0))
    arms = scene.arm_geom
    return {"left_hand": hands[0], "right_hand": hands[1], "hands": hands[0] | hands[1],
            "arms": arms[0] | arms[1], "body": collide}


class SubgoalScorer:
    """Scores one :class:`TaskSpec` on one :class:`Scene`; :meth:`reset` before every episode."""

    def __init__(self, scene: Scene, task: TaskSpec) -> None:
        self.scene, self.task = scene, task
        m = scene.model
        n = m.ngeom
        robot = _robot_masks(scene)
        self._robot_any = robot["body"]
        self._human_any = np.zeros(n, dtype=bool)
        self._human_any[scene.human_geom_ids] = True
        self._pairs = []
        for sg in task.subgoals:
            a = robot[sg.robot]
            if sg.kind == "contact":
                b = np.zeros(n, dtype=bool)
                b[scene.human_geom_ids[list(scene.body.groups[sg.human or "body"])]] = True
            else:
                b = np.zeros(n, dtype=bool)
                if scene.object_geom >= 0:
                    b[scene.object_geom] = True
            self._pairs.append((a, b))
        # A hand of an object sub-goal's group whose grip weld holds the object counts as holding it
        # (the weld keeps it at the pose of first contact, which need not stay a touching contact).
        self._grips = []
        for sg, (a, _) in zip(task.subgoals, self._pairs, strict=True):
            sides = [s for s in (0, 1) if sg.kind != "contact" and scene.grip_eq[s] >= 0 and (a & scene.hand_geom[s]).any()]
            self._grips.append(np.array([scene.grip_eq[s] for s in sides], dtype=np.int64))
        self._any_grip = any(len(g) for g in self._grips)
        # Sub-goals whose contacts count only at or above the robot's shoulders (mean z of the arm roots).
        self._above = [sg.kind == "contact" and sg.above == "robot_shoulders" for sg in task.subgoals]
        self._shoulders = np.asarray(scene.limb_body_ids[:2], dtype=np.int64)
        self._force = np.zeros(6)
        # Contacts that can matter: the robot with the person or with itself, the object with the
        # robot or the floor. The rest (the robot's feet on the floor, the person holding the
        # object) are passed over at once. Codes: 0 other, 1 robot, 2 person, 3 object, 4 floor.
        self._code = np.where(self._robot_any, 1, np.where(self._human_any, 2, 0)).astype(np.int64)
        if scene.object_geom >= 0:
            self._code[scene.object_geom] = 3
        if scene.floor_geom >= 0:
            self._code[scene.floor_geom] = 4
        table = np.zeros((5, 5), dtype=bool)
        for a, b in ((1, 1), (1, 2), (1, 3), (3, 4)):
            table[a, b] = table[b, a] = True
        self._interesting = table.ravel()
        # The same per geom pair (ngeom, ngeom): one lookup per contact on the steps where none matters.
        self._keep_pair = table[self._code[:, None], self._code[None, :]]
        self._grip_all = np.concatenate(self._grips) if self._any_grip else np.zeros(0, dtype=np.int64)
        self.reset()

    def reset(self) -> None:
        """Clear all accumulated state."""
        self.subgoals = [SubgoalResult(sg.name, sg.kind, pending=sg.kind == "object_in_hand") for sg in self.task.subgoals]
        self.failures = [FailureResult(f.kind, f.threshold) for f in self.task.failures]
        self.tracks = _Tracks()
        self.max_force_on_human = 0.0
        self.last_force = 0.0
        self.force_filtered = 0.0
        self.max_force_filtered = 0.0
        self._dt = 0.0
        self.time = 0.0
        self.robot_on_object = False
        """Whether a robot geom touched (or came within margin of) the object at the last step."""

    @property
    def failed(self) -> bool:
        """Whether any failure condition has triggered."""
        return any(f.triggered for f in self.failures)

    def mark_release(self, t: float) -> None:
        """The human let go of the object at simulated time ``t``."""
        if not self.tracks.released:
            self.tracks.released = True
            self.tracks.release_time = t

    def update(self, data: mujoco.MjData, dt: float, t: float, subevent: str | None) -> None:
        """Account for one physics step of ``dt`` s ending at time ``t`` (call after ``mj_step``)."""
        self.time = t
        self._dt = dt
        n = data.ncon
        gripped = None
        if self._any_grip:
            eq = data.eq_active
            gripped = [bool(eq[g].any()) for g in self._grips] if eq[self._grip_all].any() else [False] * len(self._grips)
        if n:
            geom = data.contact.geom[:n]
            g1, g2 = geom[:, 0], geom[:, 1]
            keep = self._keep_pair[g1, g2]
        if not n or not keep.any():
            self.robot_on_object = False
            for res in self.subgoals:
                res.current = res.low = False
            if gripped is not None and any(gripped):
                none = np.zeros(0, dtype=np.int64)
                self._score_subgoals(data, none, none, np.zeros(0, dtype=bool), dt, t, subevent, gripped)
            self._quiet_step(t)
            return
        con = data.contact
        cls = self._code[g1] * 5 + self._code[g2]
        self.robot_on_object = bool(((cls == 8) | (cls == 16)).any())  # robot–object, either order
        dist = con.dist[:n]
        touching = (dist <= 0.0) & keep
        self._score_subgoals(data, g1, g2, touching, dt, t, subevent, gripped)
        self._score_failures(data, g1, g2, np.where(keep, dist, 0.0), touching, t)

    def _quiet_step(self, t: float) -> None:
        """A step without any contact: what :meth:`update` does then, without the array work."""
        self.last_force = 0.0
        self.force_filtered -= min(1.0, self._dt / FORCE_TIME_CONSTANT) * self.force_filtered
        dropped = 1.0 if self.tracks.floor_time is not None else 0.0
        for f in self.failures:
            value = self.force_filtered if f.kind == "contact_force" else dropped if f.kind == "object_dropped" else 0.0
            bad = value > f.threshold if f.kind != "object_dropped" else value > 0
            f.worst = max(f.worst, value)
            if bad and not f.triggered:
                f.triggered, f.time = True, t

    def _pair_active(self, k: int, data: mujoco.MjData, g1: np.ndarray, g2: np.ndarray,
                     touching: np.ndarray) -> tuple[bool, bool]:
        """(counts, low): whether sub-goal ``k``'s groups touch in a contact that counts, and whether they
        touch only in contacts below its height condition."""
        a, b = self._pairs[k]
        hit = ((a[g1] & b[g2]) | (a[g2] & b[g1])) & touching
        if not hit.any():
            return False, False
        if not self._above[k]:
            return True, False
        # Contacts and body positions of one step come from the same kinematics (mj_step's forward pass).
        shoulder_z = float(data.xpos[self._shoulders, 2].mean())
        high = bool((data.contact.pos[:len(g1), 2][hit] >= shoulder_z).any())
        return high, not high

    def _score_subgoals(self, data: mujoco.MjData, g1: np.ndarray, g2: np.ndarray, touching: np.ndarray, dt: float,
                        t: float, subevent: str | None, gripped: list[bool] | None = None) -> None:
        tr = self.tracks
        obj = self.scene.object_geom
        if obj >= 0 and tr.released and tr.floor_time is None and len(g1):
            floor = self.scene.floor_geom
            on_floor = (((g1 == obj) & (g2 == floor)) | ((g2 == obj) & (g1 == floor))) & touching
            if on_floor.any():
                tr.floor_time = t
        for k, (sg, res) in enumerate(zip(self.task.subgoals, self.subgoals, strict=True)):
            counts, low = self._pair_active(k, data, g1, g2, touching) if len(g1) else (False, False)
            active = counts or bool(gripped and gripped[k])
            res.current, res.low = active, low and not active
            if active or low:
                if res.first_touch is None:
                    res.first_touch = t
                res.last_touch = t
            if sg.kind == "contact":
                if active and (not sg.subevents or subevent in sg.subevents):
                    res.contact_time += dt
                    if not res.success and res.contact_time >= sg.min_duration - 1e-9:
                        res.success, res.time = True, t
            elif sg.kind == "catch":
                if active and tr.released:
                    res.contact_time += dt
                    if not res.success and tr.floor_time is None:
                        res.success, res.time = True, t
            else:  # object_in_hand: track the current hold (it may begin while the person still holds it)
                if active:
                    res.contact_time += dt
                    last = tr.last_hold.get(sg.name)
                    if last is None or t - last > GAP + 1e-9:
                        tr.hold_since[sg.name] = t
                    tr.last_hold[sg.name] = t

    def measure_gaps(self, data: mujoco.MjData) -> list[float | None]:
        """Set and return each sub-goal's :attr:`~SubgoalResult.gap`: the smallest signed distance (m) between
        its robot group's and its other group's collidable geoms (``mj_geomDistance``, exact for convex
        shapes and meshes' convex hulls), ``None`` beyond :data:`GAP_RANGE` or without geoms."""
        out: list[float | None] = []
        for (a, b), res in zip(self._pairs, self.subgoals, strict=True):
            best = GAP_RANGE
            ga, gb = np.flatnonzero(a), np.flatnonzero(b)
            if len(gb) and len(ga):
                # Nearest candidates first (by centre distance), so that distmax shrinks fast.
                ca, cb = data.geom_xpos[ga], data.geom_xpos[gb]
                diff = ca[:, None, :] - cb[None, :, :]
                centre = norms(diff, axis=2)
                for i in np.argsort(centre, axis=None):
                    ia, ib = divmod(int(i), len(gb))
                    reach = self.scene.model.geom_rbound[ga[ia]] + self.scene.model.geom_rbound[gb[ib]]
                    if centre.flat[i] - reach > best:
                        continue
                    d = mujoco.mj_geomDistance(self.scene.model, data, int(ga[ia]), int(gb[ib]), best, None)
                    best = min(best, float(d))
            res.gap = None if best >= GAP_RANGE else best
            out.append(res.gap)
        return out

    def _score_failures(self, data: mujoco.MjData, g1: np.ndarray, g2: np.ndarray, dist: np.ndarray,
                        touching: np.ndarray, t: float) -> None:
        robot, human = self._robot_any, self._human_any
        on_human = np.flatnonzero(((robot[g1] & human[g2]) | (robot[g2] & human[g1])) & touching)
        total = 0.0
        for i in on_human:
            mujoco.mj_contactForce(self.scene.model, data, int(i), self._force)
            total += abs(self._force[0])
        self.last_force = total
        self.max_force_on_human = max(self.max_force_on_human, total)
        a = min(1.0, self._dt / FORCE_TIME_CONSTANT)
        self.force_filtered += a * (total - self.force_filtered)
        self.max_force_filtered = max(self.max_force_filtered, self.force_filtered)
        selfpen = robot[g1] & robot[g2]
        depth = float(-dist[selfpen].min()) if selfpen.any() else 0.0
        for f in self.failures:
            if f.kind == "self_collision":
                value, bad = depth, depth > f.threshold
            elif f.kind == "contact_force":
                value = self.force_filtered
                bad = value > f.threshold
            else:
                value = 1.0 if self.tracks.floor_time is not None else 0.0
                bad = value > 0
            f.worst = max(f.worst, value)
            if bad and not f.triggered:
                f.triggered, f.time = True, t

    def finish(self, t_end: float) -> None:
        """Judge the end-of-episode sub-goals (``object_in_hand``) at time ``t_end``."""
        tr = self.tracks
        for sg, res in zip(self.task.subgoals, self.subgoals, strict=True):
            if sg.kind != "object_in_hand":
                continue
            since, last = tr.hold_since.get(sg.name), tr.last_hold.get(sg.name)
            held = (
                tr.released and since is not None and last is not None and t_end - last <= GAP + 1e-9
                and last - since >= sg.min_duration - 1e-9 and tr.floor_time is None
            )
            res.success, res.time, res.pending = bool(held), (since if held else None), False
