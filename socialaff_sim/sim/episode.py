"""Run one instance through the whole loop and summarise it (the content of ``metrics.json``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import KEY_JOINTS
from ..retarget.sources import KeyJointSource
from .fall import FallWatch
from .outcome import episode_outcome
from .simulator import Simulator, StepResult
from .support import FrameSupport

__all__ = ["run_episode", "summarize", "support_summary", "support_caption", "foot_drift", "ERROR_OK"]

ERROR_OK = 0.02
"""Key-frame error (m) under which a reachable target counts as met."""


def run_episode(
    sim: Simulator,
    source: KeyJointSource,
    interaction: Interaction,
    *,
    on_frame: Callable[[Simulator, StepResult | None, str | None], None] | None = None,
) -> dict[str, Any]:
    """Replay ``interaction`` with the robot driven by ``source``; returns :func:`summarize`'s metrics, with a fall
    (:class:`~socialaff_sim.sim.fall.FallWatch`'s defaults) watched for at every frame.

    ``on_frame(sim, result, subevent)`` is called after the reset (``result`` None)
    and after every step, e.g. to render frames; its time is excluded from the
    loop's wall time.
    """
    source.reset(interaction)
    wall = 0.0
    tic = time.perf_counter()
    first = source.targets(0)
    # A causal source (the model's synthesis) declares how much of agent 1's recording it sees.
    sim.reset(interaction, placement_frames=getattr(source, "placement_frames", None))
    sim.settle(sim.retarget(first.keys, frame=0, subevent=first.subevent, contact=first.contact,
                           contact_inside=first.contact_inside, contact_inside_next=first.contact_inside_next))
    wall += time.perf_counter() - tic
    fall = FallWatch()
    fall.reset(sim)
    if on_frame is not None:
        on_frame(sim, None, first.subevent)
    while not sim.done:
        tic = time.perf_counter()
        frame = source.targets(sim.frame + 1)
        targets = sim.retarget(frame.keys, frame=sim.frame + 1, subevent=frame.subevent, contact=frame.contact,
                               contact_inside=frame.contact_inside,
                               contact_inside_next=frame.contact_inside_next)
        result = sim.step(targets, subevent=frame.subevent)
        wall += time.perf_counter() - tic
        fall.update(sim, result.time)
        if on_frame is not None:
            on_frame(sim, result, frame.subevent)
    return summarize(sim, wall, fall_time=fall.time)


def _stats(x: np.ndarray) -> dict[str, float | None]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"mean": None, "p50": None, "p95": None, "max": None}
    return {"mean": float(x.mean()), "p50": float(np.median(x)), "p95": float(np.percentile(x, 95)), "max": float(x.max())}


def foot_drift(frames: list[FrameSupport]) -> float:
    """How far a foot got from where it stood over ``frames`` (m): per foot, the diagonal of the box of its
    horizontal positions while it touched the floor (at least the farthest two positions are apart, at most
    √2 times that), the larger of the feet (0: no foot touched). Unlike the sliding path, a foot rocking or
    shaking in place adds nothing to it beyond the extent of the motion."""
    lo = np.min([f.feet_lo for f in frames], axis=0).reshape(2, 2)
    hi = np.max([f.feet_hi for f in frames], axis=0).reshape(2, 2)
    touched = np.isfinite(lo).all(axis=1)
    return float(np.linalg.norm(hi[touched] - lo[touched], axis=1).max()) if touched.any() else 0.0


def _support_stats(frames: list[FrameSupport]) -> dict[str, float | None]:
    if not frames:
        return {k: None for k in ("outside_support_mean", "outside_support_peak", "foot_slide_cm", "foot_drift_cm",
                                  "foot_slip_cm", "foot_steps", "foot_step_cm", "foot_skims", "foot_skim_cm",
                                  "penetration_cm", "torque_ratio_max", "saturated_fraction",
                                  "at_joint_limit_fraction", "torso_tilt_deg_max")}
    return {
        "outside_support_mean": float(np.mean([f.outside_mean for f in frames])),
        "outside_support_peak": float(max(f.outside_peak for f in frames)),
        "foot_slide_cm": 100.0 * float(sum(f.slide for f in frames)),
        "foot_drift_cm": 100.0 * foot_drift(frames),
        # Not the slide above (the ankle body's path): the soles' floor contacts' slip along the floor, and apart
        # from it the steps (a foot leaving the floor, rising above the clearance, landing again) and the skims (a
        # foot off the floor within the clearance) (sim/sole_slip.py).
        "foot_slip_cm": 100.0 * float(sum(f.slip for f in frames)),
        "foot_steps": int(sum(f.steps for f in frames)),
        "foot_step_cm": 100.0 * float(sum(f.step_length for f in frames)),
        "foot_skims": int(sum(f.skims for f in frames)),
        "foot_skim_cm": 100.0 * float(sum(f.skim_length for f in frames)),
        "penetration_cm": 100.0 * float(max(f.penetration for f in frames)),
        "torque_ratio_max": float(max(f.torque_ratio for f in frames)),
        "saturated_fraction": float(np.mean([f.saturated for f in frames])),
        "at_joint_limit_fraction": float(np.mean([f.at_limit for f in frames])),
        "torso_tilt_deg_max": float(max(f.tilt_deg for f in frames)),
    }


def _mode(sim: Simulator, puppet: str) -> str:
    """The physics mode's name (``puppet``: the gravity-compensated one's), with the standing control if on."""
    if sim.config.gravity_compensation:
        return puppet
    stance, balance = sim.config.stance, sim.config.balance
    name = "real weight"
    if stance is not None:
        name += ", stance control" + (" (harness let go when steady)" if stance.release else " (steadied base)")
    if balance is not None:
        name += (", physics-rate balance control (" + ("QP" if balance.solver == "qp" else "least squares")
                 + (", harness let go when steady)" if balance.release else ", on the harness)"))
    elif stance is None or not stance.release:  # nothing ever lets go of the robot
        name += ", on the harness"
    return name


def _short_mode(sim: Simulator) -> str:
    """The physics mode in a word or two, for captions that must fit a 640 px video frame (``support_summary``'s
    ``mode`` spells it out): ``puppet``, ``harness``, ``steady base`` (the harness on a steadied base), ``stance``
    (the stance control lets go), ``balance QP`` / ``balance LS`` (the balance controller lets go), ``harness+QP`` /
    ``harness+LS`` (it never does)."""
    stance, balance = sim.config.stance, sim.config.balance
    if sim.config.gravity_compensation:
        return "puppet"
    if balance is not None:
        solver = "QP" if balance.solver == "qp" else "LS"
        return f"balance {solver}" if balance.release else f"harness+{solver}"
    if stance is not None:
        return "stance" if stance.release else "steady base"
    return "harness"


def support_summary(sim: Simulator) -> dict[str, Any]:
    """Outside support (fraction of the robot's weight), foot sliding (``foot_slide_cm``: the ankle body's path
    while its foot touches the floor), the soles' slip on the floor (``foot_slip_cm``, a different figure), the steps
    and skims apart from it (``foot_steps``, ``foot_step_cm``, ``foot_skims``, ``foot_skim_cm``), penetration and
    effort of the episode just run: over all frames, and over the *contact phase* (the frames where a sub-goal's
    contact holds now)."""
    frames = [r.support for r in sim.results if r.support is not None]
    contact = [r.support for r in sim.results if r.support is not None and any(r.subgoals_now.values())]
    meter = sim.support
    return {
        "mode": _mode(sim, "gravity compensation (kinematic puppet)"),
        "robot_mass_kg": meter.mass,
        "gravity_compensation_fraction": meter.gravcomp_fraction,
        "episode": _support_stats(frames),
        "contact_phase": {"frames": len(contact), "released_frames": sum(f.outside_peak == 0.0 for f in contact),
                          **_support_stats(contact)},
    }


def support_caption(sim: Simulator) -> str:
    """One caption line: the mode in a few words (``support_summary``'s ``mode`` spells it out); this frame's outside
    support (% of the weight), the episode's foot sliding so far, this frame's largest servo force (% of its limit)
    and the torso's tilt from the vertical."""
    mode = _short_mode(sim)
    frames = [r.support for r in sim.results if r.support is not None]
    if not frames:
        return f"{mode}"
    last = frames[-1]
    return (f"{mode}: outside support {100 * last.outside_mean:.0f} %, slid "
            f"{100 * sum(f.slide for f in frames):.0f} cm, torque {100 * last.torque_ratio:.0f} %, "
            f"tilt {last.tilt_deg:.0f} deg")


def summarize(sim: Simulator, wall_seconds: float, *, fall_time: float | None = None) -> dict[str, Any]:
    """Metrics of the episode just run by ``sim`` (JSON-serialisable). ``fall_time``: the simulated time (s) the
    robot was first seen fallen (``None``: never; :class:`~socialaff_sim.sim.fall.FallWatch`)."""
    res = sim.results
    inter = sim.interaction
    assert inter is not None
    err = np.array([r.ik_error for r in res]).reshape(-1, 5)
    reach = np.array([r.reachable for r in res]).reshape(-1, 5)
    avail = np.broadcast_to(inter.key_available(), err.shape)
    ik_time = np.array([r.ik_seconds for r in res])
    sim_time = sim.time
    scorer = sim.scorer
    per_key = {
        name: {"all": _stats(err[:, k]), "reachable": _stats(err[reach[:, k] & avail[:, k], k]),
               "reachable_fraction": float(reach[:, k].mean()) if len(reach) else None}
        for k, name in enumerate(KEY_JOINTS)
    }
    ok = err[reach & avail]
    outcome, outcome_time = episode_outcome(scorer.subgoals, scorer.failures, fall_time, sim_time)
    return {
        "instance": inter.instance_id,
        "interaction": inter.label,
        "task": sim.task.interaction,
        "robot": sim.robot.name,
        "frames": inter.n_frames,
        "fps": inter.fps,
        "simulated_seconds": sim_time,
        "physics_steps_per_frame": sim.n_sub,
        "subgoals": [
            {"name": s.name, "kind": s.kind, "success": s.success, "achieved": s.success, "time": s.time,
             "contact_seconds": s.contact_time, "current_at_end": s.current,
             "first_touch": s.first_touch, "last_touch": s.last_touch,
             "in_contact_per_frame": [r.subgoals_now.get(s.name, False) for r in res],
             "gap_m_per_frame": [None if r.subgoal_gaps.get(s.name) is None else round(float(r.subgoal_gaps[s.name]), 4)
                                 for r in res]}
            for s in scorer.subgoals
        ],
        "success": outcome == "success",
        # One code per episode (sim/outcome.py): success, or the first reason it was not one.
        "outcome": outcome,
        "outcome_time": outcome_time,
        "fell_at": fall_time,
        "failures": [
            {"kind": f.kind, "threshold": f.threshold, "triggered": f.triggered, "time": f.time, "worst": f.worst}
            for f in scorer.failures
        ],
        "ik_error_m": per_key,
        "ik_error_reachable_within_2cm": float((ok <= ERROR_OK).mean()) if ok.size else None,
        "ik_ms_per_frame": _stats(ik_time * 1e3),
        "ik_iterations_mean": float(np.mean([r.ik_iterations for r in res])) if res else 0.0,
        "contact_force_on_human_n": {"max": scorer.max_force_on_human,
                                     "per_frame": [round(r.force_on_human, 3) for r in res]},
        "object_released_at": None if sim.carry is None else scorer.tracks.release_time,
        "support": support_summary(sim),
        "contact_completion": {
            "on": sim.config.contact_completion is not None,
            "weight_per_frame": [None if r.completion is None else [round(float(w), 3) for w in r.completion]
                                 for r in res],
        },
        "wall_seconds": wall_seconds,
        "real_time_factor": sim_time / wall_seconds if wall_seconds > 0 else None,
    }
