"""CPU time of the compiled kernels' start in a new process (``SynthesisConfig.kernel = "numba"``, issue 24): numba's
import, and the kernels' compilation with an empty cache or their machine code loaded from the cache.

Each measurement is a fresh Python process (``--child``) that imports the package, then times (``time.process_time``)
the reactor's start with ``kernel="numba"`` on one recording of a pickled method and its first 12 calls (the first makes
the synthesizers: the type tables and the row densities' kernel loaded or compiled; the first re-planning loads or
compiles the scores' and the choice's kernels); a ``kernel="numpy"`` process first, for comparison. The cache is a temporary folder (``NUMBA_CACHE_DIR``):
empty for the first process, filled for the next ones. Usage::

    OMP_NUM_THREADS=1 python scripts/kernel_jit_time.py --model /work/rt24/models/handover.pkl \\
        --data handover:../shared/data/handover_h2h --interaction hand_over --repeats 3

The library never imports this script.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

T0 = 10


def _child(args: argparse.Namespace) -> None:
    c0 = time.process_time()
    import pickle

    import numpy as np

    from socialaff_sim.data.growing import GrowingInteraction
    from socialaff_sim.data.specs import load_dataset
    from socialaff_sim.inference.protocol import observed_part

    c_import = time.process_time() - c0
    with open(args.model, "rb") as fh:
        method = pickle.load(fh)
    import dataclasses

    method.synthesis = dataclasses.replace(method.synthesis, kernel=args.kernel)
    data = load_dataset(args.data)
    inst = [i for i in data if i.label == (args.interaction or data[0].label)][0]
    hidden = observed_part(inst, T0)
    c1 = time.process_time()
    reactor = method.start(n_observed=T0, offline=False, rng=np.random.default_rng(0))
    c_start = time.process_time() - c1
    views = GrowingInteraction(hidden)
    c2 = time.process_time()
    for t in range(T0, min(inst.n_frames, T0 + 12)):  # the first calls: the synthesizers made, the first re-plannings
        views.append_from(hidden, t + 1)
        reactor.react(views.view(), t, t + 1)
    c_steps = time.process_time() - c2
    print(json.dumps({"import": c_import, "start": c_start, "first_steps": c_steps}))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True, help="a pickled method (scripts/bench_reactor.py --model)")
    p.add_argument("--data", required=True, help="dataset spec, e.g. handover:../shared/data/handover_h2h")
    p.add_argument("--interaction", default=None)
    p.add_argument("--repeats", type=int, default=3, help="processes after the first (cache filled)")
    p.add_argument("--kernel", default="numba", help=argparse.SUPPRESS)
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        _child(args)
        return 0
    cmd = [sys.executable, os.path.abspath(__file__), "--child", "--model", args.model, "--data", args.data]
    if args.interaction:
        cmd += ["--interaction", args.interaction]
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for k, kernel in enumerate(["numpy"] + ["numba"] * (1 + args.repeats)):
            out = subprocess.run(cmd + ["--kernel", kernel], env=env, capture_output=True, text=True, check=False)
            if out.returncode:
                sys.stderr.write(out.stderr)
                return 1
            r = json.loads(out.stdout.strip().splitlines()[-1])
            what = "numpy" if kernel == "numpy" else ("numba, empty cache" if k == 1 else "numba, cache filled")
            rows.append((what, r))
            print(f"{what:22s} import {r['import']:.3f} s  start {r['start']:.3f} s  first steps {r['first_steps']:.3f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
