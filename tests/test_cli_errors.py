"""Every sub-command given bad arguments: one line naming the flag, file or field, exit status 2, no traceback;
outputs checked before any work; multi-file outputs locked, staged and cleaned."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import socialaff_sim.data as data_pkg
from socialaff_sim._atomic import atomic_write_text, output_folder
from socialaff_sim.cli.main import main
from socialaff_sim.data import npz_format
from socialaff_sim.errors import OutputError

ROOT = Path(__file__).resolve().parents[1]
DEAD_PID = 2**22 + 12345  # above Linux's default pid_max (4 194 304): never a running process


@pytest.fixture
def places(tmp_path: Path) -> dict[str, str]:
    a_file = tmp_path / "a_file.txt"
    a_file.write_text("x")
    return {
        "file": str(a_file),                      # an existing file where a folder is expected
        "dir": str(tmp_path),                     # an existing folder where a file is expected
        "under_file": str(a_file / "out"),        # a path whose parent is a file
        "unwritable": "/proc/socialaff_test/out",  # /proc refuses new entries, even for root
        "model": str(tmp_path / "missing_model.npz"),
        "garbage": str(tmp_path / "garbage.npz"),
    }


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, list[str]]:
    rc = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return rc, [ln for ln in err.splitlines() if ln.strip()]


# (argv with {placeholders}, expected text of the error line, usage error?)
BAD = [
    (["data", "synth", "--seed", "-1"], "argument --seed: expected an integer >= 0, found -1", True),
    (["data", "synth", "--seed", "x"], "argument --seed: expected an integer >= 0, found 'x'", True),
    (["data", "synth", "--out", "{file}"], "--out: {file}: expected a folder (or a new name), found a file", False),
    (["data", "synth", "--out", "{under_file}"], "expected a folder to create", False),
    (["data", "synth", "--out", "{unwritable}"], "--out: /proc: cannot write here", False),
    (["data", "inspect", "npz:/nonexistent_socialaff"], "no such file or folder", False),
    (["data", "inspect", "bogus:x"], "dataset spec 'bogus:x': expected one of", False),
    (["data", "inspect", "synthetic:abc"], "'synthetic:SEED' with an integer seed", False),
    (["data", "inspect", "synthetic", "--units", "km"], "argument --units: invalid choice: 'km'", True),
    (["simulate", "--data", "synthetic", "--instance", "0", "--physics", "hover"],
     "argument --physics: invalid choice: 'hover'", True),
    (["demo", "--physics", "hover"], "argument --physics: invalid choice: 'hover'", True),
    (["data", "inspect", "synthetic", "--units", "mm"], "units: only npz: folders take a unit", False),
    (["data", "inspect", "synthetic", "--strict", "--lenient"], "not allowed with argument", True),
    (["data", "convert", "synthetic", "--out", "{file}"], "--out: {file}: expected a folder", False),
    (["data", "convert", "synthetic"], "the following arguments are required: --out", True),
    (["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", "{dir}"],
     "--out: {dir}: expected a file name, found a folder", False),
    (["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", "{under_file}/m.npz"],
     "expected a folder to create", False),
    (["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", "m.npz", "--subevents", "500"],
     "argument --subevents: expected an integer from 1 to 12, found 500", True),
    (["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", "m.npz", "--seed", "-1"],
     "argument --seed: expected an integer >= 0, found -1", True),
    (["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", "m.npz", "--iterations", "-2"],
     "argument --iterations: expected an integer >= 0, found -2", True),
    (["fit", "--data", "synthetic", "--interaction", "fly", "--out", "{dir}/m.npz"], "has no interaction 'fly'", False),
    (["show", "{model}"], "no such model file", False),
    (["show", "{garbage}"], "not a readable model file", False),
    (["show", "{garbage}", "--figure", "{dir}"], "--figure: {dir}: expected a file name, found a folder", False),
    (["synthesize", "--model", "{model}", "--data", "synthetic", "--instance", "0", "--out", "{dir}/s"],
     "no such model file", False),
    (["synthesize", "--model", "{model}", "--data", "synthetic", "--instance", "0", "--out", "{file}"],
     "--out: {file}: expected a folder", False),
    (["synthesize", "--model", "m", "--data", "synthetic", "--instance", "0", "--out", "o", "--observed", "0"],
     "argument --observed: expected an integer >= 1, found 0", True),
    (["simulate", "--instance", "0", "--out", "o", "--width", "-640"],
     "argument --width: expected an integer from 16 to 4096, found -640", True),
    (["simulate", "--instance", "0", "--out", "o", "--height", "100000"], "argument --height", True),
    (["simulate", "--instance", "0", "--out", "{file}", "--source", "gt"], "--out: {file}: expected a folder", False),
    (["simulate", "--instance", "0", "--out", "{dir}/sim", "--model", "{model}"], "no such model file", False),
    (["evaluate", "--data", "synthetic", "--out", "o", "--folds", "1"],
     "argument --folds: expected an integer >= 2, found 1", True),
    (["evaluate", "--data", "synthetic", "--out", "o", "--seed", "-1"], "argument --seed", True),
    (["evaluate", "--data", "synthetic", "--out", "o", "--workers", "0"], "argument --workers", True),
    (["evaluate", "--data", "synthetic", "--out", "{file}"], "--out: {file}: expected a folder", False),
    (["evaluate", "--data", "npz:{dir}/none", "--out", "{dir}/ev"], "no such file or folder", False),
    (["demo", "--iterations", "-1"], "argument --iterations: expected an integer >= 0, found -1", True),
    (["demo", "--seed", "-3"], "argument --seed", True),
    (["demo", "--out", "{file}"], "--out: {file}: expected a folder", False),
    (["nosuchcommand"], "invalid choice: 'nosuchcommand'", True),
]


@pytest.mark.parametrize("argv, expected, usage", BAD, ids=[" ".join(a) for a, _, _ in BAD])
def test_bad_arguments_end_in_one_line_and_exit_2(argv: list[str], expected: str, usage: bool, places, capsys,
                                                  tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path(places["garbage"]).write_bytes(b"PK\x03\x04 not really a zip")
    rc, lines = _run([a.format(**places) for a in argv], capsys)
    assert rc == 2
    assert lines, "no message"
    last = lines[-1]
    assert last.startswith("socialaff-sim") and ": error: " in last, last
    assert expected.format(**places) in last, last
    if not usage:
        assert len(lines) == 1, lines  # exactly one line, no usage block
    assert sorted(p.name for p in tmp_path.iterdir() if p.name not in ("a_file.txt", "garbage.npz")) == []


def test_fit_checks_out_before_loading_data(tmp_path: Path, capsys, monkeypatch) -> None:
    calls = []
    monkeypatch.setattr(data_pkg, "load_dataset", lambda *a, **k: calls.append(a))
    rc, lines = _run(["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", str(tmp_path)], capsys)
    assert rc == 2 and "--out" in lines[-1] and calls == []


def test_crafted_instance_id_cannot_make_convert_write_elsewhere(tmp_path: Path, capsys) -> None:
    src = tmp_path / "src"
    src.mkdir()
    rng = np.random.default_rng(0)
    joints = rng.normal(scale=0.15, size=(6, 2, 25, 3))
    joints[..., 2] = np.linspace(0, 1.6, 25)
    arrays = dict(format_version=np.array(1), joints=joints, joint_names=np.array(data_pkg.LAYOUTS["kinect_v2"].joint_names),
                  fps=np.array(15.0), label=np.array("shake_hands"), actors=np.array(["a", "b"]))
    for k, bad in enumerate(["../../escaped", str(tmp_path / "abs_escaped"), "nul\x00x", "y" * 300]):
        np.savez(src / f"f{k}.npz", **arrays, instance_id=np.array(bad))
    for policy in ("--strict", "--lenient"):
        rc, lines = _run(["data", "convert", f"npz:{src}", "--out", str(tmp_path / "out"), policy], capsys)
        assert rc == 2 and "instance_id" in lines[-1], lines
    names = {p.name for p in tmp_path.rglob("*")}
    assert not names & {"escaped", "abs_escaped", "out"}, names


def test_second_writer_to_the_same_out_gets_a_clear_error(tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    with output_folder(out):  # this process holds the lock: another run is writing
        rc, lines = _run(["data", "synth", "--out", str(out)], capsys)
    assert rc == 2 and f"process {os.getpid()}" in lines[-1] and "another socialaff-sim run" in lines[-1]
    assert list(out.glob("*.npz")) == []  # the refused run wrote nothing


def test_interrupted_convert_leaves_nothing_and_keeps_the_old_content(tmp_path: Path, capsys, monkeypatch) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("earlier")
    real = npz_format.save_interaction
    written = []

    def save_then_interrupt(inter, path):  # noqa: ANN001, ANN202
        if len(written) == 3:
            raise KeyboardInterrupt  # what SIGTERM (via the CLI's handler) or Ctrl-C raise
        written.append(path)
        return real(inter, path)

    monkeypatch.setattr(npz_format, "save_interaction", save_then_interrupt)
    rc, lines = _run(["data", "synth", "--out", str(out)], capsys)
    assert rc == 130 and "discarded" in lines[-1]
    assert len(written) == 3
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["keep.txt", "out"]  # no staging, tmp or lock left


def test_stale_leftovers_of_a_killed_run_are_cleaned(tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / f".out.{DEAD_PID}.staging").mkdir()
    (tmp_path / f".out.{DEAD_PID}.staging" / "half.npz").write_bytes(b"half")
    (out / f".x.npz.{DEAD_PID}.abc123.tmp").write_bytes(b"half")
    (tmp_path / ".out.lock").write_text(f"{DEAD_PID}\n")  # the killed run's lock
    alive = out / f".y.npz.{os.getpid()}.abc.tmp"  # a live writer's temporary file is left alone
    alive.write_bytes(b"")
    assert main(["data", "synth", "--out", str(out)]) == 0
    capsys.readouterr()
    leftovers = sorted(p.name for p in tmp_path.rglob(".*"))
    assert leftovers == [alive.name]
    assert len(list(out.glob("*.npz"))) == 120


def test_atomic_file_write_cleans_a_dead_writers_tmp(tmp_path: Path) -> None:
    stale = tmp_path / f".r.json.{DEAD_PID}.zz.tmp"
    stale.write_text("half")
    atomic_write_text(tmp_path / "r.json", "{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]
    with pytest.raises(OutputError, match="expected a file name, found a folder"):
        atomic_write_text(tmp_path, "x")


@pytest.mark.parametrize("argv, expected", [
    (["fit", "--data", "synthetic", "--interaction", "shake_hands", "--out", "m.npz", "--subevents", "500"],
     "--subevents"),
    (["data", "convert", "synthetic", "--out", "{file}"], "expected a folder"),
])
def test_console_process_has_no_traceback(argv: list[str], expected: str, places) -> None:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "socialaff_sim.cli.main", *[a.format(**places) for a in argv]],
                          capture_output=True, text=True, env=env, check=False)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and expected in proc.stderr.strip().splitlines()[-1]


@pytest.mark.parametrize(("argv", "code", "stream", "expected"), [
    (["--version"], 0, "stdout", "socialaff-sim "),
    (["data", "convert", "synthetic", "--out", "{file}"], 2, "stderr", "expected a folder"),
])
def test_python_dash_m_runs_the_command(argv: list[str], code: int, stream: str, expected: str, places) -> None:
    # `python -m socialaff_sim` is the command without its console script: same output, same exit status.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "socialaff_sim", *[a.format(**places) for a in argv]],
                          capture_output=True, text=True, env=env, check=False)
    assert proc.returncode == code
    assert expected in getattr(proc, stream) and "Traceback" not in proc.stderr
