"""What the contact completion stage (:mod:`~socialaff_sim.retarget.contact_completion`) reads from the scene.

The *anchors* are the spheres a task wants a robot hand on: the person's two hand spheres (for a
``contact`` sub-goal with the person's hands or wrists: the hand sphere is where a hand is met or a
wrist gripped) and the object (for ``catch`` and ``object_in_hand`` sub-goals, until a robot hand grips
it: then the contact is made and the model's motion carries it on). Each sub-goal allows the robot hands
of its group (``hands``/``arms``: both) on the anchors of its group; a sub-goal listing sub-events allows
them only during those. A ``catch`` sub-goal's *window* is open while the object is free, no robot hand grips it
and the sub-goal wants it (``ContactCompletionConfig.catch_flight`` then aims at the object's predicted flight,
from its simulated state now: :meth:`ContactAnchors.flight`). Positions are of frame t (the person's recorded pose at t, the object carried
along its recorded track, or in flight predicted from its state now), and the robot's hands as they are
now: nothing from the future.
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..retarget.contact_completion import CompletionInput
from ..retarget.flight_target import FlightState
from .human import HAND_SPHERE_RADIUS
from .scene import Scene
from .stage import key_frames
from .tasks import TaskSpec

__all__ = ["ContactAnchors", "GRAVITY", "object_in_flight", "object_radius", "offered_hand"]

GRAVITY = 9.81
"""g, m/s² (MuJoCo's default): an object in flight is predicted one frame ahead under it."""
_PERSON_SIDES = {"hands": (0, 1), "wrists": (0, 1), "left_hand": (0,), "left_wrist": (0,), "right_hand": (1,),
                 "right_wrist": (1,)}
_ROBOT_SIDES = {"hands": (0, 1), "arms": (0, 1), "left_hand": (0,), "right_hand": (1,)}
_LANDED = 0.01
"""Metres: a free object whose centre is at most this far above one radius up lies on the floor (landed)."""
_SEARCH = 100.0
"""Metres: farthest distance the nearest points are searched to (``mj_geomDistance`` fills in no points
beyond it; people start some metres apart)."""


def object_radius(shape: str, size: tuple[float, ...]) -> float:
    """The radius of the sphere a hand aims at on an object: a ball's, a cylinder's, a box's smallest half-size."""
    return float(size[0]) if shape in ("sphere", "cylinder") else float(min(size))


class ContactAnchors:
    """The anchors of one task in one physics scene: person's left hand, right hand, then the object (if any)."""

    def __init__(self, scene: Scene, task: TaskSpec) -> None:
        self.scene = scene
        B = scene.n_bones
        geoms = [int(scene.human_geom_ids[B]), int(scene.human_geom_ids[B + 1])]
        radius = [HAND_SPHERE_RADIUS, HAND_SPHERE_RADIUS]
        if scene.object_geom >= 0 and task.object is not None:
            geoms.append(int(scene.object_geom))
            radius.append(object_radius(task.object.spec.shape, task.object.spec.size))
        self.geoms = np.array(geoms, dtype=np.int64)
        self.radius = np.array(radius)
        self.shared = np.arange(len(geoms)) >= 2
        self._rules: list[tuple[tuple[str, ...], np.ndarray]] = []
        self._catches = [sg.subevents for sg in task.subgoals if sg.kind == "catch"]
        for sg in task.subgoals:
            allowed = np.zeros((2, len(geoms)), dtype=bool)
            robot = _ROBOT_SIDES.get(sg.robot, ())
            if sg.kind == "contact":
                for side in _PERSON_SIDES.get(sg.human or "", ()):
                    allowed[list(robot), side] = True
            elif len(geoms) > 2:
                allowed[list(robot), 2] = True
            self._rules.append((sg.subevents, allowed))
        self._hand_geoms = [np.flatnonzero(scene.hand_geom[s]) for s in (0, 1)]
        self._fromto = np.zeros(6)

    def allowed(self, subevent: str | None, gripped: bool) -> np.ndarray:
        """(2, A) bool: the hand–anchor pairs the task wants now (the object's only while no hand grips it)."""
        out = np.zeros((2, len(self.geoms)), dtype=bool)
        for subevents, allowed in self._rules:
            if not subevents or subevent in subevents:
                out |= allowed
        if gripped:
            out[:, 2:] = False
        return out

    def gripped(self, data: mujoco.MjData) -> bool:
        """Whether a robot hand grips the object now (its grip weld is on)."""
        sc = self.scene
        return bool(len(sc.grip_eq) and (sc.grip_eq >= 0).all() and data.eq_active[sc.grip_eq].any())

    def catch_window(self, data: mujoco.MjData, subevent: str | None, free: bool) -> bool:
        """Whether a ``catch`` sub-goal's window is open: the object ``free`` (thrown or let go), not down on the
        floor (its centre more than ``_LANDED`` above a radius up), no robot hand gripping it, and a ``catch``
        sub-goal wanting it during ``subevent`` (one listing no sub-events: always)."""
        if not free or len(self.geoms) < 3 or self.gripped(data):
            return False
        if data.qpos[self.scene.object_qadr + 2] <= self.radius[2] + _LANDED:
            return False  # landed: nothing left to catch (a robot would walk after a ball on the floor)
        return any(not subevents or subevent in subevents for subevents in self._catches)

    def flight(self, data: mujoco.MjData, lead: float) -> FlightState:
        """The free object's state now (its simulated centre and velocity, the scene's gravity, the floor at z =
        0), for a prediction ``lead`` s ahead and on (:func:`~socialaff_sim.retarget.flight_target.flight_targets`)."""
        sc = self.scene
        qa, va = sc.object_qadr, sc.object_vadr
        return FlightState(position=np.array(data.qpos[qa:qa + 3]), velocity=np.array(data.qvel[va:va + 3]),
                           lead=float(lead), gravity=float(-sc.model.opt.gravity[2]), floor=0.0)

    def nearest(self, data: mujoco.MjData) -> np.ndarray:
        """(2, A, 3) the point of each robot hand's collidable geoms nearest each anchor now (``mj_geomDistance``)."""
        m = self.scene.model
        out = np.zeros((2, len(self.geoms), 3))
        for s in (0, 1):
            for a, anchor in enumerate(self.geoms):
                best = np.inf
                for g in self._hand_geoms[s]:
                    d = mujoco.mj_geomDistance(m, data, int(g), int(anchor), _SEARCH, self._fromto)
                    if d < best:
                        best = d
                        out[s, a] = self._fromto[:3]
                if not np.isfinite(best):  # no hand geoms: the wrist frame itself
                    out[s, a] = key_frames(self.scene, data)[1 + s]
        return out

    def gather(self, data: mujoco.MjData, wrist_target: np.ndarray, wrist_commanded: np.ndarray,
               person_hands: np.ndarray, object_centre: np.ndarray | None, arm: float,
               subevent: str | None, intent: bool = False, offered: int | None = None,
               free: bool = False, inside: bool = False, catch: bool = False, flight: FlightState | None = None,
               met: bool = False) -> CompletionInput:
        """The stage's input: ``wrist_target`` (2, 3) from the model, ``wrist_commanded`` (2, 3) the wrists of
        the latest IK solution, the person's hand centres at frame t ``person_hands`` (2, 3), the object's
        centre at t (``None``: no object or it is parked), world frame; ``intent``: the source's model means to
        touch now; ``offered``: with ``intent`` and ``inside``, the person's hand held out (0 left, 1 right;
        :func:`offered_hand`), the only one of theirs the robot may meet (None: either); ``free``: the object moves freely (thrown or let go);
        ``inside``: the model's contact is a keyframe inside the sub-event; ``catch``: a catch sub-goal's window is open
        (:meth:`catch_window`); ``flight``: the free object's state now (:meth:`flight`); ``met``: the task's touches are
        met (``CompletionInput.met``).

        The hands' nearest points are the physical ones: moved by as much as the commanded wrist moves, the
        physical hand keeps its offset from the IK's (a servo's tracking error, an arm sagging under its
        weight), so the contact is aimed for the hand the person sees."""
        centre, allowed = self.wanted(data, person_hands, object_centre, subevent, offered if intent and inside else None)
        return CompletionInput(
            wrist_target=np.asarray(wrist_target, dtype=np.float64), wrist_now=np.asarray(wrist_commanded, dtype=np.float64),
            nearest=self.nearest(data), centre=centre, radius=self.radius, shared=self.shared, allowed=allowed,
            shoulder=np.array(data.xpos[self.scene.limb_body_ids[:2]], dtype=np.float64),
            arm=float(arm), intent=bool(intent),
            free=bool(free), inside=bool(inside), catch=bool(catch), flight=flight, met=bool(met),
        )

    def wanted(self, data: mujoco.MjData, person_hands: np.ndarray, object_centre: np.ndarray | None,
               subevent: str | None, offered: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The anchors' centres (A, 3), world frame, and the hand–anchor pairs the task wants now (2, A) bool
        (arguments as in :meth:`gather`; ``offered`` not None: of the person's hands only that one)."""
        centre = np.zeros((len(self.geoms), 3))
        centre[:2] = person_hands
        allowed = self.allowed(subevent, self.gripped(data))
        if len(self.geoms) > 2:
            if object_centre is None:
                allowed[:, 2] = False
            else:
                centre[2] = object_centre
        if offered is not None:
            allowed[:, 1 - offered] = False
        return centre, allowed


def offered_hand(person_keys: np.ndarray) -> int:
    """The hand the person holds out (0 left, 1 right): of their wrists, the one farther from their base (a hand
    raised for a high five or held out to be shaken, against one hanging at the side). ``person_keys`` (5, 3):
    the person's key joints (base, left wrist, right wrist, …) at the current frame; 1 when unknown."""
    keys = np.asarray(person_keys, dtype=np.float64)
    d = np.linalg.norm(keys[1:3] - keys[0], axis=1)
    if not np.isfinite(d).all():
        return 0 if np.isfinite(d[0]) and not np.isfinite(d[1]) else 1
    return int(np.argmax(d))


def object_in_flight(data: mujoco.MjData, scene: Scene, dt: float) -> np.ndarray:
    """(3,) where the free object will be after ``dt`` s of free flight from its state now, world frame."""
    p = np.array(data.qpos[scene.object_qadr:scene.object_qadr + 3])
    v = np.array(data.qvel[scene.object_vadr:scene.object_vadr + 3])
    return p + v * dt - 0.5 * GRAVITY * dt * dt * np.array([0.0, 0.0, 1.0])
