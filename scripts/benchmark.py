"""Run every speed and accuracy benchmark of the project and write docs/benchmarks.md.

Each section runs an existing script (or the CLI) as a subprocess with
``OMP_NUM_THREADS=1`` (so the figures are single-core), reads its machine-readable
result (``--json`` of the bench scripts, ``results.json`` of ``socialaff-sim
evaluate``, the wall time of ``socialaff-sim demo``) and renders one Markdown
section: the exact command, the table, the target and whether it is met. The
page's header records the machine as found at run time. A section whose command
fails says so, with the error; no figure is ever filled in by this script.

Sections: learning, synthesis, ik, physics (ik and physics share one run of
bench_sim.py), env, demo, accuracy (long: the full cross-validation). Usage::

    python scripts/benchmark.py [--quick] [--only learning,synthesis,...] [--out docs/benchmarks.md]
        [--workers 2] [--timeout 5400] [--work DIR]

``--quick`` uses small settings (few instances and iterations) to check that the
pipeline runs; its figures are labelled as such and not judged against targets.
This script is never imported by the library.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from socialaff_sim._atomic import atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
SECTIONS = ("learning", "synthesis", "ik", "physics", "env", "demo", "accuracy")
TAIL = 25  # lines of stderr shown for a failed command


# --------------------------------------------------------------------------- running commands
@dataclass(eq=False)
class Run:
    """One subprocess: its argv (with ``{py}``, ``{cli}`` and ``{tmp}`` placeholders), its JSON output."""

    key: str
    argv: list[str]
    json_name: str | None = None  # file under {tmp} the command writes, read back after it ends
    ok: bool = False
    wall_s: float = float("nan")
    error: str = ""
    data: object = None
    shown: str = ""

    def resolve(self, tmp: Path, cli: str) -> tuple[list[str], str]:
        subs = {"{py}": sys.executable, "{cli}": cli, "{tmp}": str(tmp)}
        shows = {"{py}": "python", "{cli}": "socialaff-sim", "{tmp}": "TMPXXTOKEN"}
        real = [_sub(a, subs) for a in self.argv]
        shown = "OMP_NUM_THREADS=1 " + shlex.join(_sub(a, shows) for a in self.argv).replace("TMPXXTOKEN", "$TMP")
        return real, shown


def _sub(text: str, table: dict[str, str]) -> str:
    for k, v in table.items():
        text = text.replace(k, v)
    return text


def execute(run: Run, tmp: Path, cli: str, timeout: float) -> None:
    """Run ``run`` with OMP_NUM_THREADS=1 in the checkout; fill in ok, wall_s, error and data."""
    argv, run.shown = run.resolve(tmp, cli)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    env.setdefault("MUJOCO_GL", "egl")
    log = tmp / f"{run.key}.log"
    if run.json_name is not None:
        (tmp / run.json_name).unlink(missing_ok=True)  # never read a stale result from an earlier run in --work
    print(f"[benchmark] {run.shown}", file=sys.stderr, flush=True)
    start = time.perf_counter()
    try:
        with open(log, "wb") as out:
            proc = subprocess.run(argv, cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT, timeout=timeout,
                                  check=False)
        code = proc.returncode
    except subprocess.TimeoutExpired:
        code = None
    except OSError as exc:
        run.error = f"could not start the command: {exc}"
        return
    run.wall_s = time.perf_counter() - start
    tail = "\n".join(log.read_text(errors="replace").splitlines()[-TAIL:])
    if code is None:
        run.error = f"timed out after {timeout:.0f} s; last output:\n{tail}"
        return
    if code != 0:
        run.error = f"exit code {code}; last output:\n{tail}"
        return
    if run.json_name is not None:
        path = tmp / run.json_name
        try:
            run.data = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            run.error = f"the command succeeded but its result {run.json_name} could not be read: {exc}"
            return
    run.ok = True


# --------------------------------------------------------------------------- machine facts
def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _memory() -> str:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return f"{int(line.split()[1]) / 2**20:.1f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return "unknown"


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


def _git() -> str:
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return head + (" with uncommitted changes" if dirty else "")


def _load() -> str:
    try:
        return " / ".join(f"{x:.2f}" for x in os.getloadavg()) + " (1 / 5 / 15 min)"
    except OSError:
        return "unknown"


def machine_facts() -> dict[str, str]:
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "CPU": _cpu_model(),
        "cores": f"{os.cpu_count()} logical, {usable} usable by this process",
        "memory": _memory(),
        "OS": platform.platform(),
        "Python": platform.python_version(),
        "numpy / scipy": f"{_version('numpy')} / {_version('scipy')}",
        "mujoco / mink / gymnasium": f"{_version('mujoco')} / {_version('mink')} / {_version('gymnasium')}",
        "socialaff-sim": f"{_version('socialaff-sim')}, commit {_git()}",
    }


# --------------------------------------------------------------------------- rendering helpers
def table(head: list[str], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(head) + " |", "|" + "---|" * len(head), *("| " + " | ".join(r) + " |" for r in rows)]


def verdict(value: float, target: float, *, at_least: bool, quick: bool) -> str:
    if quick:
        return "not judged (quick settings)"
    ok = value >= target if at_least else value <= target
    return "met" if ok else "**missed**"


def f(x: object, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


@dataclass
class Section:
    name: str
    title: str
    runs: list[Run]
    render: Callable[[list[Run], bool], list[str]]
    load: list[str] = field(default_factory=list)
    reused: bool = False  # every run was already made by an earlier section (ik and physics share bench_sim)


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


def _synthesis(runs: list[Run], quick: bool) -> list[str]:
    d = runs[0].data
    rows = [[label, str(r["frames"]), f(r["frames_per_s"], ".0f"), f(r["frames_per_s_with_skeleton"], ".0f"),
             f(r["key_joint_error_m"])] for label, r in d["interactions"].items()]
    errs = [r["key_joint_error_m"] for r in d["interactions"].values()]
    mean_err = sum(errs) / len(errs)
    a = d["all"]
    rows.append(["**all**", str(a["frames"]), f"**{a['frames_per_s']:.0f}**", "", f"**{mean_err:.3f}** (mean)"])
    out = table(["interaction", "frames", "frames/s (key joints)", "frames/s (+ full skeleton)", "key-joint error (m)"],
                rows)
    out += ["", f"Models fitted with {d['iterations']} MCMC iterations on 18 instances, synthesis of the held-out rest, "
            f"T0 = {d['n_observed']}; seconds are wall time.", "",
            f"- ≥ 200 synthesized frames/s on one core: {a['frames_per_s']:.0f}, "
            + verdict(a["frames_per_s"], 200.0, at_least=True, quick=quick) + ".",
            f"- Full-model key-joint error ≤ 0.07 m: {mean_err:.3f} m, "
            + verdict(mean_err, 0.07, at_least=False, quick=quick) + "."]
    return out


def _ik(runs: list[Run], quick: bool) -> list[str]:
    d = runs[0].data
    rows = [[k, str(s["instances"]), str(s["frames"]), f"{s['ik_ms_mean']:.2f} ({s['ik_ms_p95']:.2f})",
             f(s["ik_iterations_mean"], ".2f"), f"{100 * s['err_reachable_within_2cm']:.1f} % "
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
                       + f"; error ≤ 2 cm wherever reachable: {100 * s['err_reachable_within_2cm']:.1f} % within, "
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
    rows, out_lines = [], []
    for run in runs:
        if not run.ok:
            rows.append([run.key, "failed", "", "", "", ""])
            continue
        r = run.data
        rows.append([f"robot {r['robot']}, physics {r['physics']}, policy {r['policy']}", f(r["cpu_steps_per_s"], ".0f"),
                     f(r["cpu_steps_per_s_with_resets"], ".0f"), f(r["wall_steps_per_s"], ".0f"),
                     f(r["cpu_ms_per_reset"], ".0f"), f"{r['success_rate']:.2f} ({r['episodes_finished']} episodes)"])
    out = table(["setting", "steps/s (CPU)", "steps/s incl. resets (CPU)", "steps/s (wall)", "ms per reset (CPU)",
                 "replay success"], rows)
    first = runs[0]
    if first.ok:
        v = first.data["cpu_steps_per_s"]
        out_lines = [f"- ≥ 300 env steps/s in one process without rendering (default setting): {v:.0f}, "
                     + verdict(v, 300.0, at_least=True, quick=quick) + "."]
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


def _accuracy(runs: list[Run], quick: bool) -> list[str]:
    out: list[str] = []
    ev = runs[0]
    if ev.ok:
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
        out += [f"Experiment 1 on `{d['dataset']}` (`{ev.shown}`), average error (m) over the synthesized frames "
                "(key joints per interaction, then the averages):", ""]
        out += table(["method", *labels, "average key joints", "average full skeleton", "parse frame accuracy (mean)",
                      "fit + predict s (summed over tasks)"], rows)
        if "full" in avg and avg["full"]["key_joint_error_m"] is not None:
            v = avg["full"]["key_joint_error_m"]
            out += ["", f"- Full model's average key-joint error ≤ 0.07 m: {v:.3f} m, "
                    + verdict(v, 0.07, at_least=False, quick=quick) + "."]
    else:
        out += [f"`{ev.shown}` **failed**:", "", "```", ev.error, "```"]
    bl = runs[1]
    out.append("")
    if bl.ok:
        d = bl.data
        methods = d["methods"]
        rows = [[f"{name} ({', '.join(r['interactions'] or ['all'])})",
                 *(f"{f(r['average'][m]['key_joint_error_m'])} / {f(r['average'][m]['joint_error_m'])}"
                         for m in methods), f(r["wall_s"], ".0f")] for name, r in d["datasets"].items()]
        out += [f"Baselines on real recordings (`{bl.shown}`), {d['n_folds']} actor-disjoint folds, "
                "key-joint / full-skeleton error (m); `hold_last` keeps agent 1's last observed pose (a reference):", ""]
        out += table(["dataset", *methods, "wall s"], rows)
        out += [f"- {name}: skipped, {why}" for name, why in d["skipped"].items()]
    else:
        out += [f"`{bl.shown}` **failed**:", "", "```", bl.error, "```"]
    return out


# --------------------------------------------------------------------------- the sections
def sections(quick: bool, workers: int) -> dict[str, Section]:
    py, cli = "{py}", "{cli}"
    learn = ["--instances", "6", "--iterations", "5", "--interactions", "shake_hands"] if quick else []
    synth = ["--iterations", "5", "--interactions", "shake_hands"] if quick else []
    sim = Run("bench_sim", [py, "scripts/bench_sim.py", "--robots", "ours", "cmu", "--json", "{tmp}/sim.json"]
              + (["--labels", "shake_hands", "--per-label", "2"] if quick else []), "sim.json")
    steps = "200" if quick else "3000"
    env_runs = [Run("env_default", [py, "scripts/bench_env.py", "--steps", steps, "--json", "{tmp}/env.json"], "env.json")]
    if not quick:
        env_runs += [Run("env_accurate", [py, "scripts/bench_env.py", "--steps", steps, "--physics", "accurate",
                                          "--json", "{tmp}/env_accurate.json"], "env_accurate.json"),
                     Run("env_cmu", [py, "scripts/bench_env.py", "--steps", steps, "--robot", "cmu",
                                     "--json", "{tmp}/env_cmu.json"], "env_cmu.json")]
    if quick:
        demo = [Run("demo_one", [cli, "demo", "--interaction", "shake_hands", "--iterations", "3", "--out",
                                 "{tmp}/demo_one", "--no-video", "--quiet"])]
        evaluate = [cli, "evaluate", "--data", "synthetic", "--interactions", "shake_hands", "--methods",
                    "full,hmm,promp", "--folds", "2"]
        datasets = ["sbu"]
    else:
        demo = [Run("demo_all", [cli, "demo", "--out", "{tmp}/demo_all", "--no-video", "--quiet"]),
                Run("demo_one", [cli, "demo", "--interaction", "throw_catch", "--out", "{tmp}/demo_one", "--no-video",
                                 "--quiet"])]
        evaluate = [cli, "evaluate", "--data", "synthetic", "--methods", "full,v1,v2,hmm,promp", "--folds", "4"]
        datasets = ["sbu", "handover"]
    evaluate += ["--seed", "0", "--workers", str(workers), "--out", "{tmp}/evaluate", "--quiet"]
    baselines = [py, "scripts/bench_baselines.py", "--datasets", *datasets, "--out", "{tmp}/baselines",
                 "--workers", str(workers), "--seed", "0", "--json", "{tmp}/baselines.json"]
    return {
        "learning": Section("learning", "Learning (Algorithm 1), issue 3",
                            [Run("bench_learning", [py, "scripts/bench_learning.py", *learn, "--json",
                                                    "{tmp}/learning.json"], "learning.json")], _learning),
        "synthesis": Section("synthesis", "Synthesis (Algorithm 2), issue 4",
                             [Run("bench_synthesis", [py, "scripts/bench_synthesis.py", *synth, "--json",
                                                      "{tmp}/synthesis.json"], "synthesis.json")], _synthesis),
        "ik": Section("ik", "Retargeting with mink: IK time and key-frame error, issue 5", [sim], _ik),
        "physics": Section("physics", "Physics: real-time factor and ground-truth replay success, issue 5", [sim],
                           _physics),
        "env": Section("env", "Gymnasium environment, issue 6", env_runs, _env),
        "demo": Section("demo", "Demo, issue 7", demo, _demo),
        "accuracy": Section("accuracy", "Accuracy (Experiment 1), issues 4 and 7",
                            [Run("evaluate", evaluate, "evaluate/results.json"),
                             Run("bench_baselines", baselines, "baselines.json")], _accuracy),
    }


def render(sec: Section, quick: bool) -> list[str]:
    out = [f"## {sec.title}", ""]
    if quick:
        out += ["*Quick run: small settings, not the target configuration.*", ""]
    out += ["```", *dict.fromkeys(r.shown for r in sec.runs), "```", ""]
    walls = ", ".join(f"{r.key} {r.wall_s:.0f} s" for r in dict.fromkeys(sec.runs) if r.wall_s == r.wall_s)
    if sec.reused:
        out += [f"Same run as the section above (wall time: {walls or '–'}).", ""]
    else:
        out += [f"Wall time: {walls or '–'}; load average before → after: {sec.load[0]} → {sec.load[1]}.", ""]
    failed = [r for r in sec.runs if not r.ok]
    if (failed and sec.name not in ("env", "demo", "accuracy")) or all(not r.ok for r in sec.runs):
        for r in failed:
            out += [f"**Failed**: `{r.shown}`", "", "```", r.error, "```", ""]
        return out
    try:
        out += sec.render(sec.runs, quick)
    except (KeyError, TypeError, ValueError, ZeroDivisionError) as exc:
        out += [f"**Failed**: the result could not be rendered ({type(exc).__name__}: {exc})."]
    if sec.name != "accuracy":  # the accuracy section reports its own failures in place
        for r in failed:
            out += ["", f"**Failed**: `{r.shown}`", "", "```", r.error, "```"]
    return out + [""]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small settings (not the target configuration)")
    ap.add_argument("--only", default=",".join(SECTIONS), help=f"comma-separated sections of {', '.join(SECTIONS)}")
    ap.add_argument("--out", default=str(ROOT / "docs" / "benchmarks.md"), help="page to write (atomically)")
    ap.add_argument("--workers", type=int, default=2, help="process-pool workers of the accuracy section (default 2)")
    ap.add_argument("--timeout", type=float, default=5400.0, help="seconds allowed per command (default 5400)")
    ap.add_argument("--work", default=None, help="keep the commands' raw outputs in this folder (default: temporary)")
    args = ap.parse_args()
    only = [s.strip() for s in args.only.split(",") if s.strip()]
    unknown = [s for s in only if s not in SECTIONS]
    if unknown or not only:
        ap.error(f"--only: unknown section(s) {unknown}; choose from {', '.join(SECTIONS)}")
    cli = shutil.which("socialaff-sim", path=str(Path(sys.executable).parent)) or shutil.which("socialaff-sim") or ""
    tmp_ctx = tempfile.TemporaryDirectory(prefix="socialaff-bench-") if args.work is None else None
    tmp = Path(tmp_ctx.name if tmp_ctx else args.work).resolve()
    tmp.mkdir(parents=True, exist_ok=True)
    invocation = "python scripts/benchmark.py" + "".join(f" {a}" for a in sys.argv[1:])
    started = dt.datetime.now(dt.timezone.utc)
    load_before, facts, t0 = _load(), machine_facts(), time.perf_counter()
    all_secs = sections(args.quick, args.workers)
    body: list[str] = []
    try:
        for name in SECTIONS:
            if name not in only:
                continue
            sec = all_secs[name]
            sec.load.append(_load().split(" (")[0])
            sec.reused = all(run.shown for run in sec.runs)
            for run in sec.runs:
                if not run.shown:  # ik and physics share one run
                    if run.argv[0] == "{cli}" and not cli:
                        run.shown = run.resolve(tmp, "socialaff-sim")[1]
                        run.error = "the socialaff-sim command is not on PATH (pip install -e .)"
                        continue
                    execute(run, tmp, cli, args.timeout)
            sec.load.append(_load().split(" (")[0])
            body += render(sec, args.quick)
    finally:
        if tmp_ctx is not None:
            tmp_ctx.cleanup()
    total = time.perf_counter() - t0
    head = ["# Benchmarks", ""]
    if args.quick:
        head += ["> **Quick run** (`--quick`): small settings (few instances and iterations, one interaction), "
                 "**not the target configuration**. These figures only show that the benchmarks run; targets are "
                 "not judged.", ""]
    head += [f"Generated by `{invocation}` — do not edit by hand; re-run the script. Every figure comes from the "
             "command shown in its section, run as a subprocess with `OMP_NUM_THREADS=1` (single-core figures) from "
             "the repository root; `$TMP` is a temporary folder.", ""]
    facts_rows = [[k, v] for k, v in facts.items()]
    facts_rows += [["date (UTC)", started.strftime("%Y-%m-%d %H:%M")], ["load average before", load_before],
                   ["load average after", _load()], ["sections", ", ".join(only)],
                   ["total wall time", f"{total:.0f} s"]]
    head += table(["machine", ""], facts_rows) + [""]
    if not args.quick:
        head += ["Wall-clock figures depend on what else runs on the machine: compare the load averages.", ""]
    atomic_write_text(args.out, "\n".join(head + body).rstrip() + "\n")
    print(f"[benchmark] wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
