"""``FIELD=VALUE`` settings of a config dataclass on a script's command line (``--balance``, ``--foot-lock``,
``--stance``, ``--completion`` of scripts/bench_support.py and scripts/bench_demo_modes.py). A field that does not
exist or was removed, and a removed value of a field that stays, are a one-line error naming the flag (exit 2), not a
traceback. The library never imports this module."""

from __future__ import annotations

import argparse
import ast
import dataclasses

REMOVED = {
    "BalanceConfig": {**{name: "61e3f3e" for name in ("hand_weight", "hand_bandwidth", "hand_near", "hand_far",
                                                      "hand_release", "release_reach")},
                      **{name: "7c7e7ae" for name in ("torque_handover", "com_glide", "glide_rest", "glide_joints",
                                                       "release_speed")},
                      "yaw_ratio": "e4dd195", "release_level": "f948b65", "shift_strike": "7eedbfc",
                      "touch_gap": "b830275", "cop_kern": "7ad41ee", "roll_bound": "20fbacb",
                      **{name: "7ed30be" for name in ("compensation_after_touch", "hand_task_yield")},
                      **{name: "2398f3a" for name in ("single_support", "release_settled_tilt",
                                                       "release_settled_rate")}},
    "FootLockConfig": {**{name: "61e3f3e" for name in ("catch_up", "catch_up_height", "catch_up_frames",
                                                       "catch_up_quiet")},
                       **{name: "e1cb74d" for name in ("plant_physical", "replant", "replant_after", "plant_base")},
                       **{name: "7c7e7ae" for name in ("touchdown", "touchdown_height", "touchdown_frames",
                                                        "touchdown_stride")},
                       **{name: "cce7ce7" for name in ("pace", "pace_height", "pace_base")},
                       "follow_caught": "20fbacb"},
    "ContactCompletionConfig": {"planned_shoulder": "cce7ce7",
                                **{name: "d8e4b73" for name in ("base_approach", "base_approach_ramp")}},
    "StanceConfig": {name: "1d1621b" for name in ("approach_near", "approach_far")},
    "SimConfig": {"noslip_iterations": "e4dd195"},
    "SynthesisConfig": {"horizon_overrun": "7f03f2e"},
}
"""Options removed after they failed their measurements or nothing adopted them (docs/design.md), by class and field:
the removing commit."""

REMOVED_VALUES = {
    "BalanceConfig": {"com_reference": {"world": "e923256", "approach": "e923256"}},
}
"""Values removed from a field that stays (docs/design.md), by class, field and value: the removing commit."""


def field_settings(p: argparse.ArgumentParser, flag: str, cls: type, items: list[str]) -> dict[str, object]:
    """``FIELD=VALUE`` items (VALUE a Python literal) → {field: value} for fields of the dataclass ``cls``; an item
    that is malformed or names no field of ``cls``: ``p.error`` (one line naming ``flag``, exit 2)."""
    known = {f.name for f in dataclasses.fields(cls)}
    out: dict[str, object] = {}
    for item in items:
        name, eq, text = item.partition("=")
        if not eq or name not in known:
            gone = REMOVED.get(cls.__name__, {}).get(name)
            why = f"; {cls.__name__}.{name} was removed at {gone}, see docs/design.md" if gone else ""
            p.error(f"{flag} {item!r}: expected FIELD=VALUE with FIELD one of {cls.__name__}'s fields{why}")
        try:
            out[name] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            p.error(f"{flag} {item!r}: expected a Python literal after '='")
        gone = next((c for v, c in REMOVED_VALUES.get(cls.__name__, {}).get(name, {}).items() if v == out[name]), None)
        if gone:
            p.error(f"{flag} {item!r}: {cls.__name__}.{name}={out[name]!r} was removed at {gone}, see docs/design.md")
    return out
