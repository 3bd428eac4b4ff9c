"""The demo's HTML page: videos of the robot reacting, the learned structure, errors and sub-goals."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..demo.pipeline import DemoConfig, InteractionResult, physics_modes
from .html import Page, definitions, esc, figure, table, video

__all__ = ["write_demo_page", "DEMO_PAGE"]

DEMO_PAGE = "report.html"
"""File name of the page inside the demo's output folder."""


def _met(metrics: Mapping[str, Any]) -> str:
    goals = metrics.get("subgoals", [])
    return f"{sum(bool(g.get('success')) for g in goals)}/{len(goals)}"


def _failures(metrics: Mapping[str, Any]) -> list[str]:
    return [str(f.get("kind")) for f in metrics.get("failures", []) if f.get("triggered")]


def _when(goal: Mapping[str, Any] | None) -> str:
    if goal is None:
        return "–"
    if not goal.get("success"):
        return "missed"
    t = goal.get("time")
    return "met" if t is None else f"met at {t:.2f} s"


def _subgoal_table(r: InteractionResult) -> str:
    ref = {g.get("name"): g for g in r.reference.get("subgoals", [])}
    rows: list[list[Any]] = []
    for g in r.simulation.get("subgoals", []):
        other = ref.get(g.get("name"))
        rows.append([
            str(g.get("name")), str(g.get("kind", "")), _when(g), float(g.get("contact_seconds", float("nan"))),
            _when(other), float(other.get("contact_seconds", float("nan"))) if other else None,
        ])
    text = table(
        ["sub-goal", "kind", "synthesized reaction", "contact (s)", "ground-truth replay", "contact (s)"], rows,
        caption=f"Sub-goals of {r.label} scored in MuJoCo on {r.instance}: the model's reaction against the "
                "recorded second person replayed through the same retargeting and physics.",
        digits=2,
    )
    failed = _failures(r.simulation)
    failed_ref = _failures(r.reference)
    text += (f"<p class=\"note\">Failure conditions triggered — synthesized: {esc(', '.join(failed) or 'none')}; "
             f"ground-truth replay: {esc(', '.join(failed_ref) or 'none')}.</p>")
    text += ("<p class=\"note\">Outcome (the codes of docs/task_format.md) — synthesized: "
             f"{esc(str(r.simulation.get('outcome', '–')))}; ground-truth replay: "
             f"{esc(str(r.reference.get('outcome', '–')))}.</p>")
    return text


def _slip_note(cp: Mapping[str, Any]) -> str:
    """The soles' slip on the floor, the steps and the skims (not the ankle's path), when the metrics have them."""
    if cp.get("foot_slip_cm") is None:
        return ""
    return (f", the soles' contacts slipped {cp['foot_slip_cm']:.1f} cm on the floor (not the ankle's path) "
            f"besides {cp['foot_steps']} steps ({cp['foot_step_cm']:.1f} cm) and {cp.get('foot_skims', 0)} skims "
            f"({cp.get('foot_skim_cm', 0.0):.1f} cm, off the floor within 5 mm)")


def _physics_note(metrics: Mapping[str, Any]) -> str:
    """The physics mode the synthesized reaction ran in, and its honesty figures over the contact phase."""
    sup = metrics.get("support") or {}
    cp = sup.get("contact_phase") or {}
    text = f"Physics mode: {sup.get('mode', 'not recorded')}."
    if cp.get("frames") and cp.get("outside_support_mean") is not None:
        n = cp["frames"]
        text += (f" Over the contact phase ({n} frame{'' if n == 1 else 's'} with a sub-goal's contact held): "
                 "outside support "
                 f"{100 * cp['outside_support_mean']:.1f} % of the robot's weight on average (peak "
                 f"{100 * cp['outside_support_peak']:.0f} %), harness off in {cp['released_frames']} frame"
                 f"{'' if cp['released_frames'] == 1 else 's'}, feet slid "
                 f"{cp['foot_slide_cm']:.1f} cm (the ankle's path) and drifted {cp['foot_drift_cm']:.1f} cm"
                 + _slip_note(cp) + ", servos at up to "
                 f"{100 * cp['torque_ratio_max']:.0f} % of their torque limits, torso tilted up to "
                 f"{cp['torso_tilt_deg_max']:.0f}°.")
    elif sup:
        text += " No contact phase (no sub-goal's contact held)."
    return f"<p class=\"note\">{esc(text)}</p>"


def _interaction_section(r: InteractionResult, config: DemoConfig) -> str:
    parts = []
    if r.video:
        parts.append(video(
            r.video, f"The {config.robot!r} robot (green) reacting to the replayed person (red) in {r.instance}, "
                     "held out of training, synthesized causally (at each frame the model reads the person's frames "
                     "up to that one only); the object is yellow, the blue spheres are the key-joint targets sent "
                     "to the inverse kinematics. Caption, line 1: time, running sub-event; line 2, per sub-goal: "
                     "its contact now (\"now touching\", or \"now apart\" with the gap between the geoms) | "
                     "whether it was achieved and when (\"judged at the end\" for a hand-over until the episode "
                     "ends); line 3: the physics mode, this frame's outside support (% of the robot's weight), the "
                     "feet's sliding so far (the ankle's path, not the soles' slip on the floor), the largest servo torque (% of its limit) and the torso's tilt from "
                     "the vertical.",
            poster=None, width=config.width,
        ))
    else:
        parts.append(f"<p class=\"note\">Video: {esc(r.video_note)}.</p>")
    parts.append(_subgoal_table(r))
    parts.append(_physics_note(r.simulation))
    parts.append(table(
        ["sub-event", "mean duration (s)"], [[n, d] for n, d in r.subevents],
        caption="Sub-events learned by Algorithm 1 and their mean durations.", digits=2,
    ))
    parts.append(figure(r.synthesis_png, f"Key-joint tracks of {r.instance} in the interaction's canonical frame: "
                                         "recorded second person (ground truth) against the synthesized reaction, "
                                         "metres against seconds, shaded by the parsed sub-events."))
    parts.append(figure(r.groupings_png, "Joint groupings of each learned sub-event: joints of one colour share a "
                                         "functional group; grey joints are Null (not constrained)."))
    if r.contact_sheet:
        parts.append(figure(r.contact_sheet, "Frames of the simulated reaction (the image links to its full size): "
                                             "evenly spaced, with the first frame at which each sub-goal shows "
                                             "\"now touching\" and the first at which it shows as achieved in "
                                             "place of the nearest.", link=True))
    if r.seconds:
        parts.append("<p class=\"note\">Time: " + esc(", ".join(
            f"{k.replace('_', ' ')} {v:.1f} s" for k, v in r.seconds.items())) + ".</p>")
    return "\n".join(parts)


def write_demo_page(out: str | Path, results: Sequence[InteractionResult], config: DemoConfig) -> Path:
    """Write ``report.html`` into the demo's output folder ``out`` (beside its videos and figures); returns its path."""
    methods = ["full", *config.baselines]
    page = Page(
        "socialaff_sim demo",
        "A social affordance model (Shu, Ryoo & Zhu, IJCAI 2016) learned from the embedded synthetic two-person "
        f"recordings, then a MuJoCo humanoid ({config.robot!r}) reacting to people it never saw, retargeted "
        "with mink inverse kinematics and scored in physics.",
    )
    overview = [[
        r.label, r.instance, r.errors.get("full"), _met(r.simulation), _met(r.reference),
        _rtf(r.simulation.get("real_time_factor")), _contact_support(r),
    ] for r in results]
    page.section("overview", "Overview", table(
        ["interaction", "instance shown", "key-joint error of the model (m)", "sub-goals met: synthesized",
         "sub-goals met: ground truth", "real-time factor", "outside support in contact"],
        overview,
        caption="One held-out instance per interaction is simulated; the error is averaged over all held-out "
                "instances (table below). Real-time factor: simulated seconds per wall-clock second. Outside "
                "support: the synthesized reaction's support from anything but its feet (harness), mean over the "
                "frames where a sub-goal's contact holds, percent of the robot's weight (–: no such frame).",
        digits=3,
    ) + definitions([
        ("MCMC iterations (Algorithm 1)", config.iterations),
        ("held-out instances per interaction", config.n_test),
        ("robot", config.robot),
        ("physics mode", physics_modes(results) or "–"),
        ("seed", config.seed),
    ]))
    rows = [[m, *(r.errors.get(m) for r in results)] for m in methods]
    best = [set()] + [
        {min(range(len(methods)), key=lambda i, c=c: _num(rows[i][c]))} for c in range(1, len(results) + 1)
    ]
    n_test = results[0].n_test if results else 0
    page.section("errors", "Key-joint error on held-out people", table(
        ["method", *(r.label for r in results)], rows, best=best,
        caption=(
            f"Protocol: offline upper bound (SynthesisConfig.offline(): every method reads the person's whole "
            f"recorded track; the first frames of the second person are observed) on a pair-disjoint split "
            f"({n_test} test instance(s) per interaction whose actor pair never appears in training). "
            "Average distance between synthesized and recorded key joints over the synthesized frames, metres; "
            "lower is better, the best of each column in bold. The command socialaff-sim evaluate runs the "
            "k-fold comparison."
        ),
    ))
    for r in results:
        page.section(r.label, r.label.replace("_", " "), _interaction_section(r, config))
    return page.write(Path(out) / DEMO_PAGE)


def _contact_support(r: InteractionResult) -> str:
    value = r.contact_support
    return "–" if value is None else f"{100 * value:.1f} %"


def _rtf(value: object) -> str:
    return f"{value:.1f}×" if isinstance(value, (int, float)) else "–"


def _num(value: object) -> float:
    return float(value) if isinstance(value, (int, float)) and value == value else float("inf")
