"""The Markdown body of each section of scripts/benchmark.py, rendered from its commands' results.

One function per section (learning, synthesis, ik, physics, env, demo, accuracy) takes the
section's runs (``benchmark.Run``: ``data`` is the command's parsed JSON result, with ``ok``,
``shown``, ``wall_s`` and ``error``) and whether they used ``--quick`` settings, and returns the
lines of its table, its notes and its verdicts against the targets; :func:`table`, :func:`verdict`
and :func:`f` are the shared formatting. Only scripts/benchmark.py imports this module (it keeps
the functions' script-private names); the library never does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterator

    from benchmark import Run


def table(head: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(head) + " |", "|" + "---|" * len(head), *("| " + " | ".join(r) + " |" for r in rows)]


def verdict(value: float, target: float, *, at_least: bool, quick: bool) -> str:
    if quick:
        return "not judged (quick settings)"
    ok = value >= target if at_least else value <= target
    return "met" if ok else "**missed**"


def f(x: object, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


def _learning(runs: list[Run], quick: bool) -> list[str]:
    d = runs[0].data
    rows, fits = [], []
    for label, r in d["interactions"].items():
        fits.append(r["fit_s"])
        rows.append([label, f(r["frame_accuracy"]), "yes" if r["contact_joints_grouped"] else "no", f(r["atoms_s"], ".1f"),
                     f(r["init_s"], ".1f"), f(r["mcmc_s"], ".1f"), f(r["fit_s"], ".1f"), f(r["acceptance"])])
    grouped = sum(r["contact_joints_grouped"] for r in d["interactions"].values())
    n = len(d["interactions"])
    rows.append(["**mean**", f"**{d['mean_frame_accuracy']:.3f}**", f"{grouped} / {n}", "", "", "", "", ""])
    out = table(["interaction", "parse frame accuracy", "contact joints grouped", "atoms s", "init s",
                 f"MCMC s ({d['iterations']} it)", "fit s", "acceptance"], rows)
    out += ["", f"{d['instances']} training instances per interaction, seed {d['seed']}; seconds are wall time.", "",
            f"- Parse frame accuracy ≥ 0.85 averaged over the interactions: {d['mean_frame_accuracy']:.3f}, "
            + verdict(d["mean_frame_accuracy"], 0.85, at_least=True, quick=quick) + ".",
            f"- Contact joints in one group in every interaction: {grouped} / {n}, "
            + verdict(grouped, n, at_least=True, quick=quick) + ".",
            f"- Fit (100 outer iterations, ~18 instances) < 60 s on one core: slowest {max(fits):.1f} s, "
            + verdict(max(fits), 60.0, at_least=False, quick=quick) + "."]
    return out


def _failed(run: Run) -> list[str]:
    """Lines reporting a command that failed, with its error."""
    return [f"`{run.shown}` **failed**:", "", "```", run.error, "```", ""]


def _ok_runs(runs: list[Run], out: list[str]) -> Iterator[Run]:
    """The runs that succeeded; each failed one is reported into ``out`` instead."""
    for run in runs:
        if run.ok:
            yield run
        else:
            out += _failed(run)


_SYNTH_MODES = {
    "offline": "`SynthesisConfig.offline()`, as `socialaff-sim evaluate` runs the full model",
    "reactive": "`SynthesisConfig.reactive()`, causal, as the simulator and the environment run it",
    "paper": "`SynthesisConfig()`, the paper's Algorithm 2 exactly",
}


def _synthesis(runs: list[Run], quick: bool) -> list[str]:
    out: list[str] = []
    for run in _ok_runs(runs, out):
        d = run.data
        for mode, m in d["modes"].items():
            rows = [[label, str(r["frames"]), f(r["frames_per_s"], ".0f"), f(r["frames_per_s_with_skeleton"], ".0f"),
                     f(r["key_joint_error_m"])] for label, r in m["interactions"].items()]
            errs = [r["key_joint_error_m"] for r in m["interactions"].values()]
            mean_err = sum(errs) / len(errs)
            a = m["all"]
            rows.append(["**all**", str(a["frames"]), f"**{a['frames_per_s']:.0f}**", "", f"**{mean_err:.3f}** (mean)"])
            out += [f"{_SYNTH_MODES.get(mode, mode)}:", ""]
            out += table(["interaction", "frames", "frames/s (key joints)", "frames/s (+ full skeleton)",
                          "key-joint error (m)"], rows)
            out += ["", f"- ≥ 200 synthesized frames/s on one core ({mode}): {a['frames_per_s']:.0f}, "
                    + verdict(a["frames_per_s"], 200.0, at_least=True, quick=quick) + ".",
                    f"- Key-joint error ≤ 0.07 m ({mode}, this one split): {mean_err:.3f} m, "
                    + verdict(mean_err, 0.07, at_least=False, quick=quick) + ".", ""]
        out += [f"Models fitted once with {d['iterations']} MCMC iterations on 18 instances per interaction, synthesis "
                f"of the held-out rest, T0 = {d['n_observed']}; seconds are wall time. The issue's accuracy target is "
                "judged on the cross-validation in the accuracy section.", ""]
    return out


def _share(s: dict) -> str:
    """The share of reachable targets within 2 cm, with the misses counted (99.99 % is not every one)."""
    misses, total = s.get("reachable_misses"), s.get("reachable_targets")
    pct = f"{100 * s['err_reachable_within_2cm']:.2f} %"
    return pct if misses is None or total is None else f"{pct} ({misses} of {total} off)"


def _ik(runs: list[Run], quick: bool) -> list[str]:
    d = runs[0].data
    rows = [[k, str(s["instances"]), str(s["frames"]), f"{s['ik_ms_mean']:.2f} ({s['ik_ms_p95']:.2f})",
             f(s["ik_iterations_mean"], ".2f"), f"{_share(s)} "
             f"({100 * s['err_reachable_p95_m']:.1f} / {100 * s['err_reachable_max_m']:.1f} cm)",
             f"{100 * s['reachable_fraction']:.0f} %", f"{100 * s['err_all_p95_m']:.1f} cm"] for k, s in d.items()]
    out = table(["robot / interaction", "instances", "frames", "IK ms/frame, mean (p95)", "QP steps/frame",
                 "reachable targets within 2 cm (p95 / max error)", "share judged reachable", "p95 error, all targets"],
                rows)
    out.append("")
    out.append("Ground-truth agent-1 replay, whole sequences; IK time is CPU time of the calling thread.")
    out.append("")
    for k, s in d.items():
        if k.endswith("/all"):
            out.append(f"- {k}: IK ≤ 1 ms/frame (mean) {s['ik_ms_mean']:.2f} ms, "
                       + verdict(s["ik_ms_mean"], 1.0, at_least=False, quick=quick)
                       + f"; error ≤ 2 cm wherever reachable: {_share(s)} within, "
                       + verdict(s["err_reachable_within_2cm"], 1.0, at_least=True, quick=quick) + ".")
    return out


def _physics(runs: list[Run], quick: bool) -> list[str]:
    d = runs[0].data
    rows = [[k, str(s["instances"]), f"{s['real_time_factor_mean']:.1f}× ({s['real_time_factor_min']:.1f}×)",
             f"{round(s['success_rate'] * s['instances'])}/{s['instances']} ({100 * s['success_rate']:.0f} %)",
             ", ".join(f"{n} {c}" for n, c in s["failures"].items()) or "none"] for k, s in d.items()]
    out = table(["robot / interaction", "instances", "real-time factor, mean (min)", "GT replay success",
                 "failure conditions seen"], rows)
    out += ["", "Real-time factor: simulated seconds / CPU seconds of reset, settle and all steps, without rendering. "
            "Success: every sub-goal met and no failure condition.", ""]
    for k, s in d.items():
        if k.endswith("/all"):
            out.append(f"- {k}: ≥ 10× real time on one core: mean {s['real_time_factor_mean']:.1f}×, "
                       + verdict(s["real_time_factor_mean"], 10.0, at_least=True, quick=quick)
                       + f" (min {s['real_time_factor_min']:.1f}×); GT replay success "
                       f"{100 * s['success_rate']:.0f} % (reported; the target compares synthesized motion to it).")
    return out


def _env(runs: list[Run], quick: bool) -> list[str]:
    """scripts/bench_env.py: ours beside Gymnasium's Humanoid-v5 in one process (ratios per interleaved round)."""
    rows, out_lines = [], []
    for run in runs:
        if not run.ok:
            rows.append([run.key, "failed", "", "", "", "", ""])
            continue
        r = run.data
        ref = r["humanoid"]["steps_per_s_wall_with_resets"]
        for key, label in (("ours_zero", "zero residual"), ("ours_random", "random actions")):
            o = r[key]
            rows.append([f"robot {r['robot']}, physics {r['physics']}, {label}", f(o["steps_per_s_wall_with_resets"], ".0f"),
                         f(o["steps_per_s_cpu_with_resets"], ".0f"), f(ref, ".0f"), f(o["ratio_median"], ".3f"),
                         f(o["ms_per_reset_cpu_median"], ".1f"), f"{o['ms_per_reset_median']:.1f}"])
    out = table(["setting", "steps/s (wall, incl. resets)", "steps/s (CPU, incl. resets)", "Humanoid-v5 steps/s (wall)",
                 "ratio to Humanoid-v5 (median of rounds)", "ms per reset (CPU, median)", "ms per reset (wall, median)"],
                rows)
    first = runs[0]
    if first.ok:
        d = first.data
        z, rnd = d["ours_zero"]["ratio_median"], d["ours_random"]["ratio_median"]
        reset = d["ours_random"]["ms_per_reset_cpu_median"]
        out_lines = [f"- zero residual ≥ 0.3× Humanoid-v5: {z:.3f}×, " + verdict(z, 0.3, at_least=True, quick=quick) + ".",
                     f"- random actions, resets included, ≥ 0.1× Humanoid-v5: {rnd:.3f}×, "
                     + verdict(rnd, 0.1, at_least=True, quick=quick) + ".",
                     f"- reset ≤ 5 ms (CPU, median, warm): {reset:.1f} ms, " + verdict(reset, 5.0, at_least=False, quick=quick)
                     + "."]
    return out + ["", *out_lines]


def _demo(runs: list[Run], quick: bool) -> list[str]:
    rows, lines = [], []
    for run, target in zip(runs, (300.0, 60.0) if len(runs) == 2 else (60.0,), strict=True):
        rows.append([f"`{run.shown}`", f"{run.wall_s:.0f}" if run.ok else "failed", f"< {target:.0f}"])
        if run.ok:
            lines.append(f"- `{run.key}`: {run.wall_s:.0f} s, " + verdict(run.wall_s, target, at_least=False, quick=quick)
                         + ".")
    out = table(["command", "wall s", "target s"], rows)
    return out + ["", "Wall time of the whole command (interpreter start included), without rendering the video "
                  "(`--no-video`), so the targets' video step is not counted.", "", *lines]


def _experiment(ev: Run, quick: bool, *, synthetic: bool) -> list[str]:
    """Table and verdicts of one ``socialaff-sim evaluate`` run."""
    if not ev.ok:
        return _failed(ev)
    d = ev.data
    per, avg = d["per_interaction"], d["average"]
    labels = list(per)
    parse = d.get("parse_accuracy") or {}
    rows = []
    for m in avg:
        acc = [parse[lab][m] for lab in labels if m in parse.get(lab, {}) and parse[lab][m] is not None]
        rows.append([m, *(f(per[lab][m]["key_joint_error_m"]) for lab in labels), f(avg[m]["key_joint_error_m"]),
                     f(avg[m]["joint_error_m"]), f(sum(acc) / len(acc)) if acc else "–",
                     f(d.get("seconds", {}).get(m), ".1f")])
    out = [f"Experiment 1 on `{d['dataset']}` (`{ev.shown}`), average error (m) over the synthesized frames "
           "(key joints per interaction, then the averages):", ""]
    out += table(["method", *labels, "average key joints", "average full skeleton", "parse frame accuracy (mean)",
                  "fit + predict s (summed over tasks)"], rows)
    errs = {m: avg[m]["key_joint_error_m"] for m in avg if avg[m]["key_joint_error_m"] is not None}
    if "full" in errs:
        v = errs["full"]
        best = min(errs, key=errs.__getitem__)
        # Four decimals: the table's three can show a tie as a 0.001 m gap.
        out += ["", f"- Full model lowest average key-joint error of {len(errs)} methods: lowest is {best} "
                f"({errs[best]:.4f} m{'' if best == 'full' else f'; full {v:.4f} m'}), "
                + verdict(float(best == "full"), 1.0, at_least=True, quick=quick) + "."]
        if "hmm" in errs:
            out += [f"- HMM's error ≥ 2× the full model's: {errs['hmm'] / v:.2f}×, "
                    + verdict(errs["hmm"] / v, 2.0, at_least=True, quick=quick) + "."]
        if synthetic:
            out += [f"- Full model's average key-joint error ≤ 0.07 m: {v:.3f} m, "
                    + verdict(v, 0.07, at_least=False, quick=quick) + "."]
    out += _paired_line(d.get("paired"))
    return out + [""]


def _paired_line(paired: dict | None) -> list[str]:
    """One line per comparison (against hold, against the best baseline): each method minus the
    reference, with its bootstrap interval (``results.json``'s ``paired``)."""
    out = []
    for entry in (paired or {}).values():
        cells = entry.get("differences", {}).get("key_joint_error_m")
        if not cells:
            continue
        level = f"{100 * entry['confidence']:g} %"
        parts = [f"{m} {c['mean_m']:+.4f} [{c['low_m']:+.4f}, {c['high_m']:+.4f}] {c['verdict']}" for m, c in cells.items()]
        out.append(f"- Paired key-joint differences to {entry['reference']} (m, {level} bootstrap interval over the test "
                   "instances; the variation from refitting is not in it): " + "; ".join(parts) + ".")
    return out


def _simsynth(runs: list[Run], quick: bool) -> list[str]:
    out: list[str] = []
    for run in _ok_runs(runs, out):
        d = run.data
        st = d["settings"]
        mode = st.get("synthesis", "online")
        what = ("online: the synthesis reacts causally to the human, `SynthesisConfig.reactive()`" if mode == "online" else
                "offline: the synthesis reads the replayed human's whole recording first, as the evaluation does")
        rows = []
        for label, r in d["summary"].items():
            g, y = r["gt"], r["synth"]
            name = "**all**" if label == "all" else label
            rows.append([name, str(r["instances"]), f"{g['success_rate']:.2f}", f"{y['success_rate']:.2f}",
                         f(r["ratio"], ".2f"), f(y.get("key_joint_error_m")),
                         ", ".join(y.get("commonest_failures", [])) or "–"])
        out += [f"`{run.shown}` ({what}):", ""]
        out += table(["interaction", "test instances", "GT replay success", "synthesized success", "ratio",
                      "synthesized key-joint error (m)", "commonest synthesized failures"], rows)
        ratio = d["summary"]["all"]["ratio"]
        out += ["", f"{st['folds_run']} of {st['folds']} pair-disjoint folds, models fitted with {st['iterations']} MCMC "
                f"iterations on each fold's training instances, robot `{st['robot']}`, T0 = {st['n_observed']}; the robot "
                "is placed from agent 1's first T0 frames for synthesized motion, from the whole recording for the replay.",
                "", f"- Synthesized ({mode}) sub-goal success ≥ 90 % of the ground-truth replay's: {ratio:.2f}, "
                + verdict(ratio if ratio is not None else 0.0, 0.90, at_least=True, quick=quick) + ".", ""]
    return out


def _accuracy(runs: list[Run], quick: bool) -> list[str]:
    out: list[str] = []
    for ev in runs[:-1]:
        out += _experiment(ev, quick, synthetic=ev.key == "evaluate")
    bl = runs[-1]
    if bl.ok:
        d = bl.data
        methods = d["methods"]
        rows = [[f"{name} ({', '.join(r['interactions'] or ['all'])})",
                 *(f"{f(r['average'][m]['key_joint_error_m'])} / {f(r['average'][m]['joint_error_m'])}"
                         for m in methods), f(r["wall_s"], ".0f")] for name, r in d["datasets"].items()]
        out += [f"Baselines on real recordings (`{bl.shown}`), {d['n_folds']} pair-disjoint folds, "
                "key-joint / full-skeleton error (m); `hold_last` keeps agent 1's last observed pose (a reference):", ""]
        out += table(["dataset", *methods, "wall s"], rows)
        out += [f"- {name}: skipped, {why}" for name, why in d["skipped"].items()]
    else:
        out += _failed(bl)[:-1]
    return out
