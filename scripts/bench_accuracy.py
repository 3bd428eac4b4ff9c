"""Accuracy sweep: ``socialaff-sim evaluate`` with every method on the synthetic set and the shared recordings.

One run of the CLI per dataset (same protocol, preset, seed and methods for all), each a subprocess
with ``OMP_NUM_THREADS=1`` under ``nice``; the script reads each run's ``results.json`` and renders a
Markdown section: per dataset the exact command, wall time, machine load, the key-joint table per
interaction, the full-skeleton average and the paired differences against ``hold`` and against the
best baseline with their 95 % intervals. The section is rewritten after every dataset, so a long sweep
that is stopped keeps what finished. Usage::

    python scripts/bench_accuracy.py --out DIR [--datasets synthetic sbu handover nuisi]
        [--protocol causal] [--preset default] [--methods full,v1,v2,hmm,promp,ridge,gru,hold,constvel]
        [--folds 4] [--workers 2] [--seed 0] [--replicate 0] [--max-folds sbu=1 ...] [--max-test handover=8 ...]
        [--data-root ../shared/data] [--reuse sbu=OLD/sbu_causal_default/results.json ...]
        [--doc docs/benchmarks.md]

``--doc`` replaces the section between this script's markers in that file (appends it at the end the
first time). Splits: ``pair`` for the synthetic set, SBU and the handovers, ``block`` for NuiSI (each
class is one recording of one pair). The library never imports this script.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

from socialaff_sim.evaluation.report import horizon_lines

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
DATASETS = {  # name: (spec with {root} for the shared data folder, split)
    "synthetic": ("synthetic", "pair"),
    "sbu": ("sbu:{root}/sbu_kinect_interaction", "pair"),
    "handover": ("handover:{root}/handover_h2h", "pair"),
    "nuisi": ("nuisi:{root}/nuisi_v1", "block"),
}
METHODS = "full,v1,v2,hmm,promp,ridge,gru,hold,constvel"
START, END = "<!-- bench_accuracy:start -->", "<!-- bench_accuracy:end -->"


def _load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):  # e.g. run from an exported snapshot of a commit
        return os.environ.get("SOCIALAFF_COMMIT", "unknown")


def _f(x: object, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


def render(name: str, command: str, run: dict[str, object], results: dict | None) -> list[str]:
    """The Markdown of one dataset's run."""
    lines = [f"### {name}", "", "```", command, "```", ""]
    lines.append(f"Wall time {run['wall_s']:.0f} s; load average before → after: {run['load_before']} → {run['load_after']}.")
    if results is None:
        return lines + ["", f"**The run failed** (exit {run['rc']}): {run.get('error', '')}", ""]
    lines += ["", f"**{results['title']}**", ""]
    if results.get("reused"):
        lines += [f"Not run again: {', '.join(results['reused']['methods'])}, taken from `{results['reused']['from']}` "
                  "(an earlier run with the same data, folds, seed and protocol); the paired comparisons are recomputed "
                  "over all methods.", ""]
        inner = results["reused"].get("earlier")
        while inner:  # that file had itself reused rows
            lines[-1:-1] = [f"That file took {', '.join(inner['methods'])} from `{inner['from']}`."]
            inner = inner.get("earlier")
    labels = list(results["per_interaction"])
    methods = list(results["average"])
    lines.append("Key-joint error (m) per interaction and averaged over the interactions; full-skeleton average; fit + predict s summed over tasks.")
    lines += ["", "| method | " + " | ".join(labels) + " | **average** | full skeleton | s |",
              "|---|" + "---:|" * (len(labels) + 3)]
    for m in methods:
        cells = [_f(results["per_interaction"][lab][m]["key_joint_error_m"]) for lab in labels]
        avg = results["average"][m]
        lines.append(f"| {m} | " + " | ".join(cells) + f" | **{_f(avg['key_joint_error_m'])}** | "
                     f"{_f(avg['joint_error_m'])} | {results['seconds'][m]:.0f} |")
    n_test = {lab: results["per_interaction"][lab][methods[0]]["n_test"] for lab in labels}
    lines += ["", "Test instances: " + ", ".join(f"{k} {v}" for k, v in n_test.items()) + "."]
    for key, entry in results.get("paired", {}).items():
        ref = entry["reference"]
        what = "`hold`" if key == "hold" else f"the best baseline (`{ref}`)"
        lines += ["", f"Paired key-joint differences to {what}, m, {100 * entry['confidence']:g} % stratified bootstrap "
                  "interval over the test instances (negative: lower than the reference):", ""]
        lines += ["| method | difference | interval | verdict |", "|---|---:|---:|---|"]
        for m, d in entry["differences"]["key_joint_error_m"].items():
            lines.append(f"| {m} | {d['mean_m']:+.4f} | [{d['low_m']:+.4f}, {d['high_m']:+.4f}] | {d['verdict']} |")
    return lines + horizon_lines(results, heading="####") + [""]


def write_section(path: Path, body: list[str], doc: Path | None) -> None:
    text = "\n".join(body) + "\n"
    path.write_text(text)
    if doc is None:
        return
    page = doc.read_text() if doc.exists() else ""
    block = f"{START}\n{text}{END}\n"
    if START in page and END in page:
        page = page[: page.index(START)] + block + page[page.index(END) + len(END) + 1 :]
    else:
        page = page.rstrip("\n") + "\n\n" + block
    doc.write_text(page)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, type=Path, help="work folder (one sub-folder per dataset)")
    ap.add_argument("--datasets", nargs="+", default=list(DATASETS), choices=list(DATASETS))
    ap.add_argument("--protocol", default="causal", choices=("causal", "paper", "offline"))
    ap.add_argument("--preset", default="default", choices=("default", "paper"))
    ap.add_argument("--methods", default=METHODS)
    ap.add_argument("--folds", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--replicate", type=int, default=0,
                    help="method replicate (`socialaff-sim evaluate --replicate`): the same folds, another random stream")
    ap.add_argument("--max-folds", nargs="*", default=[], metavar="DATASET=N",
                    help="run only the first N folds of a dataset (time-limited runs; the table says so)")
    ap.add_argument("--max-test", nargs="*", default=[], metavar="DATASET=N",
                    help="limit the test instances per fold of a dataset (time-limited runs; the table says so)")
    ap.add_argument("--reuse", nargs="*", default=[], metavar="DATASET=FILE",
                    help="an earlier results.json of that dataset (same folds, seed, protocol): its methods not in "
                    "--methods are taken from it (`socialaff-sim evaluate --reuse`; the tables say so)")
    ap.add_argument("--data-root", type=Path, default=DATA, help=f"the shared recordings (default {DATA})")
    ap.add_argument("--doc", type=Path, help="Markdown file whose accuracy-sweep section is replaced")
    args = ap.parse_args(argv)
    limits = {k: int(v) for k, v in (item.split("=", 1) for item in args.max_test)}
    fold_limits = {k: int(v) for k, v in (item.split("=", 1) for item in args.max_folds)}
    reuse = dict(item.split("=", 1) for item in args.reuse)
    args.out.mkdir(parents=True, exist_ok=True)
    when = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    body = [f"## Accuracy, causal-first evaluation (issue 23): `{args.protocol}` protocol, preset `{args.preset}`", "",
            f"*Measured at commit {_commit()}, started {when}, {os.cpu_count()} CPUs shared with other jobs "
            f"(`nice -n 10`, `OMP_NUM_THREADS=1`, {args.workers} workers). Command: "
            f"`python scripts/bench_accuracy.py {' '.join(map(shlex.quote, (argv if argv is not None else sys.argv[1:])))}`.*", ""]
    section = args.out / f"accuracy_{args.protocol}_{args.preset}.md"
    for name in args.datasets:
        spec, split = DATASETS[name]
        spec = spec.format(root=args.data_root)
        out = args.out / f"{name}_{args.protocol}_{args.preset}"
        cmd = ["nice", "-n", "10", sys.executable, "-m", "socialaff_sim.cli.main", "evaluate", "--data", spec,
               "--methods", args.methods, "--protocol", args.protocol, "--split", split, "--preset", args.preset,
               "--folds", str(args.folds), "--seed", str(args.seed), "--workers", str(args.workers),
               "--out", str(out), "--quiet"]
        if args.replicate:
            cmd += ["--replicate", str(args.replicate)]
        if name in limits:
            cmd += ["--max-test", str(limits[name])]
        if name in fold_limits:
            cmd += ["--max-folds", str(fold_limits[name])]
        if name in reuse:
            cmd += ["--reuse", reuse[name]]
        shown = "OMP_NUM_THREADS=1 " + " ".join(shlex.quote(c) for c in cmd[3:]).replace(sys.executable, "python")
        shown = shown.replace("python -m socialaff_sim.cli.main", "socialaff-sim")
        run: dict[str, object] = {"load_before": _load()}
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, env={**os.environ, "OMP_NUM_THREADS": "1"}, capture_output=True, text=True)
        run.update(wall_s=time.perf_counter() - t0, load_after=_load(), rc=proc.returncode)
        results = None
        if proc.returncode == 0:
            results = json.loads((out / "results.json").read_text())
        else:
            run["error"] = " ".join(proc.stderr.strip().splitlines()[-3:])
        print(f"{name}: exit {proc.returncode}, {run['wall_s']:.0f} s", flush=True)
        body += render(name, shown, run, results)
        write_section(section, body, args.doc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
