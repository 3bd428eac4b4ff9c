"""``socialaff-sim evaluate``: cross-validation of the methods under one protocol and split (Experiment 1 of the paper)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .._atomic import output_folder
from ..data import load_dataset
from ..errors import ConfigError
from ..evaluation import DEFAULT_N_OBSERVED, EvaluationConfig, evaluate, format_tables, write_results
from ..evaluation.crossval import EXECUTORS, PRESETS
from ..evaluation.merge import check_reusable, reuse_results
from ..evaluation.splits import SPLITS
from ..evaluation.streaming import PROTOCOLS
from ..report import write_evaluation_page
from .help_format import HelpFormatter
from .validate import add_data_options, declare_outputs, int_range, non_negative_int, positive_int

__all__ = ["register", "run"]

DEFAULT_METHODS = "full,v1,v2,hmm,promp,ridge,hold,constvel"


def _names(values: list[str] | None) -> list[str]:
    """Accept both ``a b`` and ``a,b``."""
    return [n.strip() for v in values or [] for n in v.split(",") if n.strip()]


def _read_earlier(path: str) -> dict:
    """The ``results.json`` named by ``--reuse``, checked before any fit runs."""
    try:
        earlier = json.loads(Path(path).read_text())
    except OSError as exc:
        raise ConfigError(f"--reuse {path}: cannot read it ({exc.strerror or exc})") from exc
    except json.JSONDecodeError as exc:
        raise ConfigError(f"--reuse {path}: expected a results.json written by `socialaff-sim evaluate`, not valid JSON ({exc.msg}, line {exc.lineno})") from exc
    missing = [k for k in ("dataset", "settings", "average", "per_interaction", "per_instance", "latency_ms", "seconds") if not isinstance(earlier, dict) or k not in earlier]
    if missing:
        raise ConfigError(f"--reuse {path}: expected a results.json written by `socialaff-sim evaluate`, missing field {missing[0]!r}")
    return earlier


def run(args: argparse.Namespace) -> int:
    """Load the data, run the evaluation, write DIR/results.{json,md,png} and print the tables."""
    dataset = load_dataset(args.data, policy=args.policy, units=args.units)
    config = EvaluationConfig(
        n_folds=args.folds,
        n_observed=args.n_observed,
        seed=args.seed,
        replicate=args.replicate,
        executor=args.executor,
        workers=args.workers,
        address=args.address,
        protocol=args.protocol,
        split=args.split,
        preset=args.preset,
        max_folds=args.max_folds,
        max_test=args.max_test,
    )
    methods = _names([args.methods])
    earlier = _read_earlier(args.reuse) if args.reuse else None
    if earlier is not None:
        check_reusable(earlier, dataset.name, config, _names(args.interactions) or list(dataset.labels), args.reuse)
    results = evaluate(
        dataset,
        methods,
        interactions=_names(args.interactions) or None,
        config=config,
        progress=None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True)),
    )
    if earlier is not None:
        results = reuse_results(results, earlier, args.reuse)
    with output_folder(args.out) as staging:  # results.json/.md/.png together; a second writer is refused
        staged = write_results(results, staging)
    paths = {k: Path(args.out) / p.relative_to(staging) for k, p in staged.items()}
    page = write_evaluation_page(args.out)
    print(format_tables(results))
    print("wrote " + ", ".join(str(p) for p in [*paths.values(), page]))
    if "chart" not in paths:
        print("bar chart skipped: matplotlib is not installed (pip install socialaff-sim[plot])")
    print(f"next: open {page.resolve().as_uri()} in a browser")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``evaluate``."""
    p = subparsers.add_parser(
        "evaluate",
        help="k-fold cross-validation of the methods under one protocol and split (the paper's Experiment 1)",
        epilog="example:\n  socialaff-sim evaluate --data synthetic --interactions shake_hands --methods full,hmm,promp,hold,constvel "
        "--folds 4 --out eval/\n  then open eval/report.html (all five synthetic interactions with every method: about 20 minutes on 2 cores)",
        formatter_class=HelpFormatter,
        description=(
            "Fit each method on the training folds of each interaction class and measure the average "
            "distance between its synthesized agent-1 skeleton and the ground truth over the synthesized "
            "frames. Every method runs under the same protocol (default causal: frame t from agent 0's "
            "frames <= t), enforced by the evaluator. Writes OUT/results.json, OUT/results.md (tables "
            "naming the protocol, split and preset, with paired differences against hold and the best "
            "baseline), OUT/results.png and OUT/report.html."
        ),
    )
    p.add_argument(
        "--data", required=True, metavar="SPEC",
        help="dataset spec: sbu:PATH, handover:PATH, nuisi:PATH, hhoi:PATH, npz:DIR or synthetic[:SEED]",
    )
    p.add_argument("--interactions", nargs="+", metavar="NAME", help="classes to evaluate (default: all in the data)")
    p.add_argument(
        "--methods", default=DEFAULT_METHODS, metavar="LIST",
        help=f"comma-separated methods (default: {DEFAULT_METHODS}); baselines: hmm, promp, ridge, hold, constvel, and gru with the [neural] extra (torch)",
    )
    p.add_argument(
        "--protocol", choices=PROTOCOLS, default=PROTOCOLS[0],
        help="causal (default): frame t of agent 1 from agent 0's frames <= t; paper: Algorithm 2 as written "
        "(blocks of 5 frames from agent 0's frames <= the block's first); offline: agent 0's whole track (an upper bound)",
    )
    p.add_argument(
        "--split", choices=SPLITS, default=SPLITS[0],
        help="pair (default): no test actor pair in training; actor: no test actor in training (needs actor ids); "
        "recording: no test recording in training; block: contiguous blocks of each recording (optimistic)",
    )
    p.add_argument("--preset", choices=PRESETS, default=PRESETS[0], help="configurations of full/v1/v2 (default: default)")
    p.add_argument("--folds", type=int_range(2), default=4, help="cross-validation folds per class (default 4)")
    p.add_argument(
        "--max-folds", type=positive_int, metavar="N",
        help="run only the first N of the folds (time-limited runs; the tables say so; default: all)",
    )
    p.add_argument(
        "--max-test", type=positive_int, metavar="N",
        help="at most N test instances per fold (time-limited runs; the tables say so; default: all)",
    )
    p.add_argument(
        "--n-observed", type=int_range(1), default=DEFAULT_N_OBSERVED, metavar="T0",
        help=f"frames of agent 1 observed before synthesis (default {DEFAULT_N_OBSERVED})",
    )
    p.add_argument(
        "--reuse", metavar="FILE",
        help="an earlier results.json of the same data, folds, seed and protocol: its methods that --methods does "
        "not name are taken from it instead of being fitted again (the tables say so; paired comparisons are recomputed)",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--seed", type=non_negative_int, default=0, help="run seed for the folds and every method (default 0)")
    p.add_argument(
        "--replicate", type=non_negative_int, default=0, metavar="R",
        help="method replicate: R >= 1 runs every method with another random stream on the same folds, to measure "
        "the spread of its own randomness (default 0)",
    )
    p.add_argument(
        "--executor", choices=EXECUTORS, default="process",
        help="process: local process pool (default); ray: a Ray cluster (pip install socialaff-sim[distributed]); "
        "serial: this process",
    )
    p.add_argument("--address", help="Ray cluster address (with --executor ray; default: start a local instance)")
    p.add_argument("--workers", type=positive_int, help="parallel workers (default: all CPUs)")
    add_data_options(p)
    declare_outputs(p, out="folder")
    p.set_defaults(func=run)
