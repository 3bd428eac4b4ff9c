"""scripts/benchmark.py: runs a bench script in a subprocess and writes the page from its result.

Only the cheapest section (learning, ``--quick``: 6 instances, 5 iterations, one interaction,
a few seconds) is run; the figures themselves are not asserted (no timed assertions), only that
the page carries what the script measured, with the machine facts and the command.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import load_script

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "benchmark.py"


def test_quick_learning_page(tmp_path: Path) -> None:
    out, work = tmp_path / "bench.md", tmp_path / "work"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--only", "learning", "--out", str(out), "--work", str(work)],
        cwd=ROOT, capture_output=True, text=True, check=False,
        env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")),
    )
    assert proc.returncode == 0, proc.stderr
    page = out.read_text()
    # header: machine facts read at run time
    for fact in ("| CPU |", "| cores |", "| memory |", "| Python |", "| numpy / scipy |", "| mujoco / mink / gymnasium |",
                 "| date (UTC) |", "| load average before |", "| load average after |"):
        assert fact in page, fact
    assert f"| Python | {sys.version.split()[0]} |" in page
    assert "Quick run" in page and "not the target configuration" in page
    # the exact command, single-core
    assert ("OMP_NUM_THREADS=1 python scripts/bench_learning.py --instances 6 --iterations 5 "
            "--interactions shake_hands --json $TMP/learning.json") in page
    # the table, carrying the figure the bench script wrote to its JSON
    result = json.loads((work / "learning.json").read_text())
    acc = result["interactions"]["shake_hands"]["frame_accuracy"]
    row = re.search(r"^\| shake_hands \| ([0-9.]+) \| (yes|no) \|", page, flags=re.M)
    assert row is not None, page
    assert row.group(1) == f"{acc:.3f}"
    assert "| interaction | parse frame accuracy |" in page
    assert "not judged (quick settings)" in page
    assert "## Synthesis" not in page  # --only skips the other sections


def test_failed_command_is_reported(tmp_path: Path) -> None:
    bm = load_script("benchmark")
    run = bm.Run("broken", ["{py}", "-c", "import sys; print('no such figure'); sys.exit(3)"], "missing.json")
    bm.execute(run, tmp_path, "", timeout=None)  # no wall-clock limit in tests (a loaded machine is slow)
    assert not run.ok and run.data is None
    assert "exit code 3" in run.error and "no such figure" in run.error
    sec = bm.Section("learning", "Learning", [run], bm._learning, load=["0.1", "0.2"])
    text = "\n".join(bm.render(sec, quick=False))
    assert "**Failed**" in text and "exit code 3" in text
    assert "| interaction |" not in text  # no table without a result


def test_library_does_not_import_scripts() -> None:
    offenders = [str(p.relative_to(ROOT)) for p in (ROOT / "socialaff_sim").rglob("*.py")
                 if re.search(r"^\s*(from|import)\s+(scripts|benchmark)\b", p.read_text(), flags=re.M)]
    assert offenders == []


def test_kept_sections_carry_their_own_run() -> None:
    bm = load_script("benchmark")
    page = "\n".join([
        "# Benchmarks", "", "| machine | |", "|---|---|", "| socialaff-sim | 0.1.0, commit abc1234 |",
        "| date (UTC) | 2026-01-01 10:00 |", "",
        "## Learning (Algorithm 1), issue 3", "", "old learning table", "",
        "## Demo, issue 7", "", "*Measured at commit def5678, 2026-02-02 11:00 UTC.*", "", "demo table", "",
    ])
    kept = bm.kept_sections(page, {"learning": "Learning (Algorithm 1), issue 3", "demo": "Demo, issue 7",
                                   "env": "Gymnasium environment, issue 6"})
    assert set(kept) == {"learning", "demo"}  # a section the page lacks is not invented
    assert kept["learning"][:4] == ["## Learning (Algorithm 1), issue 3", "",
                                    "*Measured at commit abc1234, 2026-01-01 10:00 UTC.*", ""]
    assert "old learning table" in kept["learning"]
    assert kept["demo"][2] == "*Measured at commit def5678, 2026-02-02 11:00 UTC.*"  # its own line, not the header's
    assert sum(ln.startswith("*Measured") for ln in kept["demo"]) == 1


def test_keep_others_reruns_only_the_chosen_section(tmp_path: Path) -> None:
    out = tmp_path / "bench.md"
    out.write_text("\n".join([
        "# Benchmarks", "", "| socialaff-sim | 0.1.0, commit abc1234 |", "| date (UTC) | 2026-01-01 10:00 |", "",
        "## Learning (Algorithm 1), issue 3", "", "OLD LEARNING", "",
        "## Synthesis (Algorithm 2), issue 4", "", "OLD SYNTHESIS", "",
    ]) + "\n")
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--only", "learning", "--keep-others", "--out", str(out)],
        cwd=ROOT, capture_output=True, text=True, check=False,
        env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")),
    )
    assert proc.returncode == 0, proc.stderr
    page = out.read_text()
    assert "OLD LEARNING" not in page and "OLD SYNTHESIS" in page
    learning, synthesis = page.index("## Learning"), page.index("## Synthesis")
    assert learning < synthesis  # the page keeps the sections' order
    assert "*Measured at commit abc1234, 2026-01-01 10:00 UTC.*" in page[synthesis:]
    own = re.search(r"\*Measured at commit (.+?), (\d{4}-\d\d-\d\d \d\d:\d\d) UTC\.\*", page[learning:synthesis])
    assert own is not None and own.group(1) != "abc1234"
    assert "| sections | learning; kept from earlier runs: synthesis |" in page


@pytest.mark.parametrize("keep_others", [False, True])
def test_other_scripts_sections_are_never_dropped(tmp_path: Path, keep_others: bool) -> None:
    out = tmp_path / "bench.md"
    out.write_text("\n".join([
        "# Benchmarks", "", "| socialaff-sim | 0.1.0, commit abc1234 |", "| date (UTC) | 2026-01-01 10:00 |", "",
        "## Reading guide", "", "GUIDE TEXT", "",
        "## Learning (Algorithm 1), issue 3", "", "OLD LEARNING", "",
        "## Synthesis (Algorithm 2), issue 4", "", "OLD SYNTHESIS", "",
        "## Contact completion (issue 25)", "", "APPENDED BY BENCH_CONTACT", "",
        "## Accuracy sweep (issue 23)", "", "APPENDED BY BENCH_ACCURACY", "",
    ]) + "\n")
    argv = [sys.executable, str(SCRIPT), "--quick", "--only", "learning", "--out", str(out)]
    proc = subprocess.run(argv + (["--keep-others"] if keep_others else []), cwd=ROOT, capture_output=True,
                          text=True, check=False, env=dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl")))
    assert proc.returncode == 0, proc.stderr
    page = out.read_text()
    assert "OLD LEARNING" not in page  # the re-run section is replaced
    assert ("OLD SYNTHESIS" in page) is keep_others  # the script's own sections follow --keep-others
    guide, learning = page.index("## Reading guide"), page.index("## Learning")
    contact, sweep = page.index("APPENDED BY BENCH_CONTACT"), page.index("APPENDED BY BENCH_ACCURACY")
    assert page.index("| machine |") < guide < learning < contact < sweep  # each where it was
    assert "GUIDE TEXT" in page[guide:learning]
    assert page.count("## Contact completion (issue 25)") == 1


def test_foreign_sections_split_at_the_first_own_section() -> None:
    bm = load_script("benchmark")
    page = "# B\n\n## A\n\na\n\n## Mine\n\nm\n\n## Z\n\nz\n"
    lead, rest = bm.foreign_sections(page, {"Mine"})
    assert lead == ["## A", "", "a", ""] and rest == ["## Z", "", "z", ""]
    lead, rest = bm.foreign_sections(page, {"A"})  # inverted: the own section first, the others after it
    assert lead == [] and rest == ["## Mine", "", "m", "", "## Z", "", "z", ""]


def test_accuracy_verdicts_and_paired_line_from_a_results_file(monkeypatch: pytest.MonkeyPatch) -> None:
    # A real evaluation (toy data, serial) with a method registered as "full", rendered as the page would.
    from test_evaluation import HoldLastPose, toy_dataset

    from socialaff_sim.evaluation import METHODS, EvaluationConfig, evaluate

    monkeypatch.setitem(METHODS, "full", HoldLastPose)
    results = evaluate(toy_dataset(seed=3, per_pair=2), ["full", "promp", "hold"], config=EvaluationConfig(executor="serial", seed=0))
    run = load_script("benchmark").Run("evaluate", [])
    run.ok, run.data, run.shown = True, json.loads(json.dumps(results)), "socialaff-sim evaluate ..."
    sections = load_script("_bench_sections")
    lines = sections._experiment(run, False, synthetic=True)
    text = "\n".join(lines)
    cell = results["paired"]["hold"]["differences"]["key_joint_error_m"]["promp"]
    assert cell["verdict"] == "lower"  # ProMP follows the human's arm, holding the pose does not
    assert "lowest is promp" in text and "**missed**" in text
    assert ("Paired key-joint differences to hold (m, 95 % bootstrap interval over the test instances; the variation "
            "from refitting is not in it): ") in text
    assert f"promp {cell['mean_m']:+.4f} [{cell['low_m']:+.4f}, {cell['high_m']:+.4f}] lower" in text
    best = results["paired"]["best_baseline"]
    assert best["reference"] == "promp" and "Paired key-joint differences to promp (m, 95 %" in text
