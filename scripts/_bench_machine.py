"""The machine a benchmark ran on, as found at run time, for the header of docs/benchmarks.md.

:func:`machine_facts`: the CPU, cores, memory, OS, the versions of Python and of the libraries that set the
figures, and the commit of the checkout (with a mark when it has uncommitted changes); :func:`load_average`: the
load averages. Only scripts/benchmark.py imports this module.
"""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


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


def load_average() -> str:
    """The load averages over 1, 5 and 15 minutes, as text (``unknown`` where the system does not say)."""
    try:
        return " / ".join(f"{x:.2f}" for x in os.getloadavg()) + " (1 / 5 / 15 min)"
    except OSError:
        return "unknown"


def machine_facts() -> dict[str, str]:
    """The header's rows (what -> value) for the machine this process runs on."""
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
