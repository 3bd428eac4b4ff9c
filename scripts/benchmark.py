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
        [--workers 2] [--timeout 5400] [--work DIR] [--keep-others]

Every section starts with the commit and time of the run that measured it. ``--keep-others``
re-runs only the ``--only`` sections and keeps the others from the page already at ``--out``
(a section from a page written before sections carried that line gets it from the page's header).
Sections of the page that this script does not produce (appended by other bench scripts, or the
reading guide at the top) are always kept verbatim: those before this script's first section stay
right under the header, the others follow this script's sections in their order.

``--quick`` uses small settings (few instances and iterations) to check that the
pipeline runs; its figures are labelled as such and not judged against targets.
Each section's Markdown is rendered by scripts/_bench_sections.py, the machine's facts are read by
scripts/_bench_machine.py. This script is never imported by the library.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from socialaff_sim._atomic import atomic_write_text

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # run as `python scripts/benchmark.py` it is sys.path[0]; the tests load this file by path
    sys.path.append(_HERE)
from _bench_machine import load_average, machine_facts  # noqa: E402
from _bench_sections import _accuracy, _demo, _env, _ik, _learning, _physics, _simsynth, _synthesis, table  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SECTIONS = ("learning", "synthesis", "ik", "physics", "simsynth", "env", "demo", "accuracy")
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


# --------------------------------------------------------------------------- the sections
@dataclass
class Section:
    name: str
    title: str
    runs: list[Run]
    render: Callable[[list[Run], bool], list[str]]
    load: list[str] = field(default_factory=list)
    reused: bool = False  # every run was already made by an earlier section (ik and physics share bench_sim)


def sections(quick: bool, workers: int) -> dict[str, Section]:
    py, cli = "{py}", "{cli}"
    learn = ["--instances", "6", "--iterations", "5", "--interactions", "shake_hands"] if quick else []
    synth = ["--iterations", "5", "--interactions", "shake_hands"] if quick else []
    sim = Run("bench_sim", [py, "scripts/bench_sim.py", "--robots", "ours", "cmu", "--json", "{tmp}/sim.json"]
              + (["--labels", "shake_hands", "--per-label", "2"] if quick else []), "sim.json")
    simsynth = ["--interactions", "shake_hands", "--quick", "--iterations", "3", "--max-test", "2"] if quick else []
    bench_env = ["--rounds", "1", "--steps", "100", "--stage-steps", "0"] if quick else ["--rounds", "5", "--steps", "400"]
    env_runs = [Run("env_default", [py, "scripts/bench_env.py", *bench_env, "--json", "{tmp}/env.json"], "env.json")]
    if not quick:
        env_runs += [Run("env_accurate", [py, "scripts/bench_env.py", *bench_env, "--physics", "accurate",
                                          "--json", "{tmp}/env_accurate.json"], "env_accurate.json"),
                     Run("env_cmu", [py, "scripts/bench_env.py", *bench_env, "--robot", "cmu",
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
    accuracy = [Run("evaluate", evaluate, "evaluate/results.json")]
    if not quick:  # the full model on the real recordings beside the project, where they are
        shared = ROOT.parent / "shared" / "data"
        real = [("sbu", "sbu_kinect_interaction", "shaking_hands", "full,v1,v2,hmm,promp"),
                ("handover", "handover_h2h", "hand_over", "full,v1,v2,hmm,promp")]
        for kind, folder, label, methods in real:
            if (shared / folder).is_dir():
                accuracy.append(Run(f"evaluate_{kind}", [
                    cli, "evaluate", "--data", f"{kind}:{shared / folder}", "--interactions", label, "--methods",
                    methods, "--folds", "4", "--seed", "0", "--workers", str(workers), "--out", f"{{tmp}}/evaluate_{kind}",
                    "--quiet"], f"evaluate_{kind}/results.json"))
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
        "simsynth": Section("simsynth", "Synthesized motion in physics: sub-goal success against the ground truth, issue 5",
                            [Run("bench_sim_synth", [py, "scripts/bench_sim_synth.py", *simsynth, "--workers",
                                                     str(workers), "--json", "{tmp}/simsynth.json"], "simsynth.json"),
                             Run("bench_sim_synth_offline", [py, "scripts/bench_sim_synth.py", *simsynth, "--synthesis",
                                                             "offline", "--workers", str(workers), "--json",
                                                             "{tmp}/simsynth_offline.json"], "simsynth_offline.json")],
                            _simsynth),
        "env": Section("env", "Gymnasium environment, issue 6", env_runs, _env),
        "demo": Section("demo", "Demo, issue 7", demo, _demo),
        "accuracy": Section("accuracy", "Accuracy (Experiment 1), issues 4 and 7",
                            [*accuracy, Run("bench_baselines", baselines, "baselines.json")], _accuracy),
    }


def render(sec: Section, quick: bool, provenance: str = "") -> list[str]:
    out = [f"## {sec.title}", ""] + ([provenance, ""] if provenance else [])
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


PROVENANCE = "*Measured at commit {commit}, {date} UTC.*"
"""The line under each section's title saying which run produced it (pages merge sections of several runs)."""


def kept_sections(page: str, titles: dict[str, str]) -> dict[str, list[str]]:
    """Sections of an earlier ``page`` by name (``titles``: name -> title), each as its lines, with a
    provenance line taken from that page's header where the section has none of its own."""
    facts = dict(re.findall(r"^\| (socialaff-sim|date \(UTC\)) \| (.+?) \|$", page, flags=re.M))
    commit = facts.get("socialaff-sim", "?").split("commit ")[-1]
    fallback = PROVENANCE.format(commit=commit, date=facts.get("date (UTC)", "?"))
    chunks = re.split(r"^(?=## )", page, flags=re.M)
    by_title = {c.splitlines()[0][3:].strip(): c.rstrip("\n").splitlines() for c in chunks if c.startswith("## ")}
    out = {}
    for name, title in titles.items():
        lines = by_title.get(title)
        if lines is None:
            continue
        if not any(ln.startswith("*Measured at commit ") for ln in lines[:4]):
            lines = lines[:2] + [fallback, ""] + lines[2:]
        out[name] = lines + [""]
    return out


def foreign_sections(page: str, own_titles: set[str]) -> tuple[list[str], list[str]]:
    """The ``## `` sections of ``page`` whose titles are not in ``own_titles``, verbatim, as lines:
    those before the page's first own section (kept under the header) and those after it."""
    chunks = [c for c in re.split(r"^(?=## )", page, flags=re.M) if c.startswith("## ")]
    lead: list[str] = []
    rest: list[str] = []
    seen_own = False
    for chunk in chunks:
        if chunk.splitlines()[0][3:].strip() in own_titles:
            seen_own = True
            continue
        (rest if seen_own else lead).extend(chunk.rstrip("\n").splitlines() + [""])
    return lead, rest


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small settings (not the target configuration)")
    ap.add_argument("--only", default=",".join(SECTIONS), help=f"comma-separated sections of {', '.join(SECTIONS)}")
    ap.add_argument("--out", default=str(ROOT / "docs" / "benchmarks.md"), help="page to write (atomically)")
    ap.add_argument("--workers", type=int, default=2, help="process-pool workers of the accuracy section (default 2)")
    ap.add_argument("--timeout", type=float, default=5400.0, help="seconds allowed per command (default 5400)")
    ap.add_argument("--work", default=None, help="keep the commands' raw outputs in this folder (default: temporary)")
    ap.add_argument("--keep-others", action="store_true",
                    help="keep the sections not in --only from the page already at --out (each says which run made it)")
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
    load_before, facts, t0 = load_average(), machine_facts(), time.perf_counter()
    all_secs = sections(args.quick, args.workers)
    kept: dict[str, list[str]] = {}
    lead: list[str] = []
    rest: list[str] = []
    if Path(args.out).is_file():
        old_page = Path(args.out).read_text(encoding="utf-8")
        # Other scripts' sections are evidence this script cannot re-create: never drop them.
        lead, rest = foreign_sections(old_page, {sec.title for sec in all_secs.values()})
        if args.keep_others:
            others = {n: sec.title for n, sec in all_secs.items() if n not in only}
            kept = kept_sections(old_page, others)
    provenance = PROVENANCE.format(commit=facts["socialaff-sim"].split("commit ")[-1],
                                   date=started.strftime("%Y-%m-%d %H:%M"))
    body: list[str] = []
    try:
        for name in SECTIONS:
            if name not in only:
                body += kept.get(name, [])
                continue
            sec = all_secs[name]
            sec.load.append(load_average().split(" (")[0])
            sec.reused = all(run.shown for run in sec.runs)
            for run in sec.runs:
                if not run.shown:  # ik and physics share one run
                    if run.argv[0] == "{cli}" and not cli:
                        run.shown = run.resolve(tmp, "socialaff-sim")[1]
                        run.error = "the socialaff-sim command is not on PATH (pip install -e .)"
                        continue
                    execute(run, tmp, cli, args.timeout)
            sec.load.append(load_average().split(" (")[0])
            body += render(sec, args.quick, provenance)
    finally:
        if tmp_ctx is not None:
            tmp_ctx.cleanup()
    total = time.perf_counter() - t0
    head = ["# Benchmarks", ""]
    if args.quick:
        head += ["> **Quick run** (`--quick`): small settings (few instances and iterations, one interaction), "
                 "**not the target configuration**. These figures only show that the benchmarks run; targets are "
                 "not judged.", ""]
    head += [f"The sections {', '.join(f'“{all_secs[n].title}”' for n in SECTIONS)} are generated by "
             f"`python scripts/benchmark.py` (this page last by `{invocation}`) — do not edit them by hand; re-run "
             "the script. Every figure comes from the "
             "command shown in its section, run as a subprocess with `OMP_NUM_THREADS=1` (single-core figures) from "
             "the repository root; `$TMP` is a temporary folder. The other sections were written by the bench "
             "scripts their commands name and are kept as they are when this script re-runs. The decisions behind "
             "these figures, with their evidence, are in [design.md](design.md).", ""]
    facts_rows = [[k, v] for k, v in facts.items()]
    facts_rows += [["date (UTC)", started.strftime("%Y-%m-%d %H:%M")], ["load average before", load_before],
                   ["load average after", load_average()],
                   ["sections", ", ".join(only) + (f"; kept from earlier runs: {', '.join(kept)}" if kept else "")],
                   ["total wall time", f"{total:.0f} s"]]
    head += table(["machine", ""], facts_rows) + [""]
    if not args.quick:
        head += ["Wall-clock figures depend on what else runs on the machine: compare the load averages.", ""]
    atomic_write_text(args.out, "\n".join(head + lead + body + rest).rstrip() + "\n")
    print(f"[benchmark] wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
