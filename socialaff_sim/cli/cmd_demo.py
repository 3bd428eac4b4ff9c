"""``socialaff-sim demo``: the main job on the embedded synthetic dataset (no downloads)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .._atomic import output_folder
from .validate import add_physics_option, declare_outputs, non_negative_int
from ..report import write_demo_page
from .help_format import HelpFormatter

__all__ = ["register"]


def _run(args: argparse.Namespace) -> int:
    from ..data.synthetic import INTERACTIONS
    from ..demo import DemoConfig, run_demo

    labels = [args.interaction] if args.interaction else list(INTERACTIONS)
    config = DemoConfig(iterations=args.iterations, robot=args.robot, mjcf=args.mjcf, video=not args.no_video,
                        seed=args.seed, contact_completion=not args.no_contact_completion,
                        physics=args.physics)
    start = time.perf_counter()
    done = 0
    total = 3 * len(labels)

    def progress(message: str) -> None:
        nonlocal done
        done += 1
        print(f"[{done}/{total} {time.perf_counter() - start:6.1f} s] {message}", file=sys.stderr, flush=True)

    with output_folder(args.out) as staging:  # the report and its files appear together; a second run is refused
        results = run_demo(staging, labels, config, progress=progress if not args.quiet else None)
    out = Path(args.out)
    page = write_demo_page(out, results, config)
    print(f"\n{'interaction':<14}{'key-joint error m (full / hmm / promp)':>40}{'sub-goals (synth / gt)':>26}")
    for r in results:
        errs = " / ".join(f"{r.errors.get(m, float('nan')):.3f}" for m in ("full", *config.baselines))
        sub = lambda m: f"{sum(g['success'] for g in m['subgoals'])}/{len(m['subgoals'])}"  # noqa: E731
        print(f"{r.label:<14}{errs:>40}{sub(r.simulation) + ' / ' + sub(r.reference):>26}")
    notes = {r.video_note for r in results if not r.video}
    for note in notes:
        print(f"video: {note}", file=sys.stderr)
    print(f"\nwrote {page} and {out / 'report.md'} (with figures{' and videos' if not notes else ''}) "
          f"in {time.perf_counter() - start:.0f} s")
    print(f"next: open {page.resolve().as_uri()} in a browser; fit your own data with `socialaff-sim fit --help`")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``demo``."""
    p = subparsers.add_parser(
        "demo",
        help="learn, synthesize, simulate and report on the embedded synthetic dataset",
        description="The whole loop on the embedded synthetic dataset (nothing is downloaded): learn each "
        "interaction's model, synthesize the robot's reaction to held-out people, compare with the baselines, "
        "simulate it in MuJoCo and write OUT/report.html with the videos (about 3-4 minutes for all five).",
        epilog="example:\n  socialaff-sim demo --interaction shake_hands --out demo_out   # about 40 s\n"
        "  then open demo_out/report.html in a browser",
        formatter_class=HelpFormatter,
    )
    p.add_argument("--interaction", help="one interaction (default: all five)")
    p.add_argument("--out", default="demo_out", help="output folder (default: demo_out)")
    p.add_argument("--iterations", type=non_negative_int, default=0,
                   help="MCMC iterations after Algorithm 1's initial parse (default 0, the library's default)")
    p.add_argument("--robot", default="ours",
                   help="robot to simulate: ours, cmu, unitree_h1, unitree_g1 (these two need --mjcf) or a mapping "
                        ".toml (default ours)")
    p.add_argument("--mjcf", help="the robot's MJCF file, for robots whose model the project does not ship "
                                  "(unitree_h1: your h1.xml; unitree_g1: your g1_29dof.xml)")
    p.add_argument("--no-video", action="store_true", help="skip rendering")
    p.add_argument("--no-contact-completion", action="store_true",
                   help="send the scaled targets to the IK as they are (no blending of a wrist onto the contact "
                        "the synthesized reaction is making; docs/design.md)")
    add_physics_option(p)
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed of the synthetic data and of every sampler")
    declare_outputs(p, out="folder")
    p.set_defaults(func=_run)
