"""The command line of ``scripts/train_residual.py``: one flag per field of its ``Settings`` (plus the run's own
flags), and the settings they give."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import Any

__all__ = ["parser", "settings_from_args"]

# Fields with their own add_argument below (lists, optional numbers, switches); every other field is a plain flag.
_SPECIAL = ("labels", "max_frames", "control_dt", "data", "split", "residual_groups", "residual_tau", "reach_scale",
            "use_sde", "eval_constant", "residual_labels", "action_bias", "target_kl",
            "policy_seed")
_TUPLES = {"labels": "interactions", "data": "data", "split": "split", "residual_groups": "residual_groups",
           "eval_constant": "eval_constant", "residual_labels": "residual_labels", "action_bias": "action_bias"}


def _seconds_or_none(text: str) -> float | None:
    """``--control-dt`` (``--residual-tau``): seconds, or ``none`` for one env step per data frame (no filter)."""
    return None if text.strip().lower() == "none" else float(text)


def parser(settings_type: type, doc: str | None) -> argparse.ArgumentParser:
    """The script's parser; defaults from ``settings_type()`` (``train_residual.Settings``)."""
    d = settings_type()
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True,
                    help="output folder")
    ap.add_argument("--models", type=Path, default=None,
                    help="load <interaction>.npz from here instead of fitting")
    ap.add_argument("--interactions", nargs="+", default=list(d.labels))
    for f in dataclasses.fields(settings_type):
        if f.name not in _SPECIAL:
            ap.add_argument("--" + f.name.replace("_", "-"), type=type(f.default), default=f.default)
    ap.add_argument("--max-frames", type=int, default=None)
    ap.add_argument("--residual-groups", nargs="+", default=list(d.residual_groups), metavar="JOINT[+JOINT...]",
                    help="one offset per group of key joints (e.g. base left_wrist+right_wrist); default: one per key joint")
    ap.add_argument("--residual-tau", type=_seconds_or_none, default=d.residual_tau, metavar="SECONDS",
                    help="low-pass filter the residual offset with this time constant (default: none)")
    ap.add_argument("--reach-scale", type=float, default=d.reach_scale, metavar="METRES",
                    help="task-frame residual: the base's offset and one reach per hand toward its target, "
                         "at most this far (default: the plain residual)")
    ap.add_argument("--use-sde", action="store_true", help="gSDE exploration (noise held for --sde-sample-freq steps)")
    ap.add_argument("--target-kl", type=float, default=d.target_kl, metavar="KL",
                    help="PPO stops an update's epochs once the approximate KL exceeds 1.5 times this (default: none)")
    ap.add_argument("--policy-seed", type=int, default=d.policy_seed, metavar="SEED",
                    help="seed PPO and the training resets with this instead of --seed (split, models, selection "
                         "and held-out episodes keep --seed; default: --seed)")
    ap.add_argument("--eval-constant", nargs="+", type=float, default=list(d.eval_constant), metavar="A",
                    help="also play this constant action (policy units) on the held-out episodes")
    ap.add_argument("--residual-labels", nargs="+", default=list(d.residual_labels), metavar="LABEL",
                    help="the residual acts on these interactions only (zeros elsewhere; training episodes of these "
                         "only); default: every interaction")
    ap.add_argument("--action-bias", nargs="+", type=float, default=list(d.action_bias), metavar="A",
                    help="add this constant (policy units) to the policy's action on the acting interactions, so "
                         "training starts from it (default: none)")
    ap.add_argument("--data", nargs="+", default=list(d.data), metavar="SPEC",
                    help="recorded dataset specs (handover:PATH sbu:PATH nuisi:PATH ...); default: synthetic")
    ap.add_argument("--split", nargs="+", default=list(d.split), metavar="[KIND=]NAME",
                    help=f"split of the recorded data, per dataset kind (default: {' '.join(d.split)})")
    ap.add_argument("--reference", type=Path, default=None, metavar="JSON",
                    help="the learning curve's zero-residual reference from a --reference-only run's reference.json "
                         "(same settings) instead of playing the training instances again")
    ap.add_argument("--reference-only", action="store_true",
                    help="fit the models and play the zero residual on the training instances only; write "
                         "reference.json and stop (no training, no held-out episode)")
    ap.add_argument("--control-dt", type=_seconds_or_none, default=d.control_dt,
                    help=f"env control period in s (default {d.control_dt}); 'none': one env step per data frame")
    ap.add_argument("--budget-minutes", type=float, default=None,
                    help="stop training after the first rollout that ends past this much wall time (checkpoint "
                         "evaluations included); the results record the steps trained, and --timesteps with that "
                         "number reproduces the policy")
    return ap


def settings_from_args(settings_type: type, args: argparse.Namespace) -> Any:
    """``settings_type(...)`` from the parsed flags (list flags become tuples)."""
    kw = {f.name: getattr(args, f.name) for f in dataclasses.fields(settings_type) if f.name not in _TUPLES}
    return settings_type(**kw, **{name: tuple(getattr(args, flag)) for name, flag in _TUPLES.items()})
