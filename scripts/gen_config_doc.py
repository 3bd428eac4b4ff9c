"""Generate docs/config.md: every field of every config dataclass, with its symbol, unit, default and paper value.

The table is read from the code, so it cannot drift from it (tests/test_config_doc.py fails when
docs/config.md is stale):

* every frozen dataclass named ``...Config`` in the package is listed, in the order of the layers;
* a field's docstring starts with ``SYMBOL [UNIT]: meaning`` (the symbol is the paper's notation where
  there is one and may be left out; the unit is ``—`` for a dimensionless number, a count, a flag or a
  choice); the generator refuses a field without a docstring or without that tag;
* a class docstring may group the fields by concept in a section ``Fields by concept`` whose items
  are ``- Concept: field, field, ...`` (continuation lines indented); it must then name every field
  exactly once. A class without the section is one concept (its docstring's first line says which);
* the paper value is ``XConfig.paper()``'s field where the class has that classmethod (the paper
  preset), else ``—``.

Usage::

    python scripts/gen_config_doc.py           # write docs/config.md
    python scripts/gen_config_doc.py --check   # exit 1 if docs/config.md is not what the code gives
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import importlib
import inspect
import pkgutil
import re
import sys
import textwrap
from collections.abc import Iterable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import socialaff_sim  # noqa: E402

DOC = ROOT / "docs" / "config.md"
LAYER_ORDER = ("data", "model", "learning", "inference", "baselines", "retarget", "sim", "environment", "evaluation", "demo", "cli")
"""Sub-packages in the order of the layers (pyproject.toml's import-linter contract): the order of the sections."""

TAG = re.compile(r"^(?:(?P<symbol>\S(?:.*?\S)?) )?\[(?P<unit>[^\]]+)\]: (?P<meaning>.*)$", re.S)
"""``SYMBOL [UNIT]: meaning`` at the start of a field's docstring (the symbol optional)."""

CONCEPT_HEADER = "Fields by concept"
ONE_CONCEPT = "(one concept)"
"""The concept of every field of a class without a ``Fields by concept`` section."""


class ConfigDocError(Exception):
    """A config class whose fields are not documented as this script expects; the message lists every problem."""


@dataclasses.dataclass(frozen=True)
class FieldDoc:
    """One row of the table."""

    name: str
    symbol: str
    unit: str
    meaning: str
    default: str
    paper: str


@dataclasses.dataclass(frozen=True)
class ClassDoc:
    """One config class: its rows grouped by concept, in order."""

    name: str
    module: str
    summary: str
    concepts: tuple[tuple[str, tuple[FieldDoc, ...]], ...]
    has_paper: bool


def config_classes(package: Any = socialaff_sim) -> list[type]:
    """Every dataclass named ``...Config`` defined in the package, in layer order, then by module and name."""
    found: dict[str, type] = {}
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if (
                inspect.isclass(obj) and obj.__module__ == module.__name__ and name.endswith("Config")
                and dataclasses.is_dataclass(obj)
            ):
                found[f"{obj.__module__}.{name}"] = obj

    def key(cls: type) -> tuple[int, str, str]:
        parts = cls.__module__.split(".")
        layer = parts[1] if len(parts) > 1 else ""
        rank = LAYER_ORDER.index(layer) if layer in LAYER_ORDER else len(LAYER_ORDER)
        return rank, cls.__module__, cls.__name__

    return sorted(found.values(), key=key)


def attribute_docstrings(cls: type) -> dict[str, str]:
    """The docstring literal that follows each annotated field in the class body (``{}`` entries missing)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body  # type: ignore[attr-defined]
    out: dict[str, str] = {}
    for stmt, nxt in zip(body, [*body[1:], None]):
        if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
            if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) and isinstance(nxt.value.value, str):
                out[stmt.target.id] = inspect.cleandoc(nxt.value.value)
    return out


def concept_groups(cls: type, names: list[str]) -> tuple[list[tuple[str, list[str]]], list[str]]:
    """The class docstring's ``Fields by concept`` groups (or one group, :data:`ONE_CONCEPT`) and the problems found."""
    lines = inspect.cleandoc(cls.__doc__ or "").splitlines()
    if CONCEPT_HEADER not in lines:
        return [(ONE_CONCEPT, list(names))], []
    groups: list[tuple[str, list[str]]] = []
    for line in lines[lines.index(CONCEPT_HEADER) + 1:]:
        if not line.strip() or set(line.strip()) == {"-"}:
            if groups and not line.strip():
                break
            continue
        if line.startswith("- "):
            concept, _, rest = line[2:].rpartition(": ")
            groups.append((concept.strip(), []))
        elif line.startswith(" ") and groups:
            rest = line
        else:
            break
        groups[-1][1].extend(f.strip() for f in rest.split(",") if f.strip())
    listed = [f for _, fs in groups for f in fs]
    problems = [f"{cls.__name__}: {CONCEPT_HEADER} names {f!r}, which is not a field" for f in listed if f not in names]
    problems += [f"{cls.__name__}: {CONCEPT_HEADER} names {f!r} more than once" for f in sorted({f for f in listed if listed.count(f) > 1})]
    problems += [f"{cls.__name__}.{f}: in no concept of {CONCEPT_HEADER}" for f in names if f not in listed]
    return groups, problems


def _value(v: Any) -> str:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return f"{type(v).__name__}()"
    return repr(v)


def _default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def _meaning(text: str) -> str:
    """The first sentence, RST roles reduced to code spans."""
    text = " ".join(text.split())
    text = re.sub(r":[a-z]+:`~?([^`]+)`", lambda m: "`" + m.group(1).rsplit(".", 1)[-1] + "`", text)
    text = text.replace("``", "`")
    first = re.split(r"(?<=[.;])\s+(?=[A-Z`(\"])", text, maxsplit=1)[0]
    return first[:1].upper() + first[1:] if first[:1].isascii() else first  # a symbol (λ) keeps its case


def class_doc(cls: type) -> ClassDoc:
    """The rows of one config class; :class:`ConfigDocError` lists every undocumented field."""
    fields = [f for f in dataclasses.fields(cls) if f.init]
    names = [f.name for f in fields]
    docs = attribute_docstrings(cls)
    paper_of = getattr(cls, "paper", None)
    paper = paper_of() if callable(paper_of) else None
    problems: list[str] = []
    rows: dict[str, FieldDoc] = {}
    for f in fields:
        doc = docs.get(f.name)
        if doc is None:
            problems.append(f"{cls.__name__}.{f.name}: no docstring")
            continue
        m = TAG.match(doc)
        if m is None:
            problems.append(f"{cls.__name__}.{f.name}: docstring does not start with 'SYMBOL [UNIT]: ' or '[UNIT]: '")
            continue
        default = _default(f)
        pv = "—"
        if paper is not None:
            value = getattr(paper, f.name)
            pv = _value(value) if value == default else f"**{_value(value)}**"
        rows[f.name] = FieldDoc(
            name=f.name, symbol=m.group("symbol") or "", unit=m.group("unit"), meaning=_meaning(m.group("meaning")),
            default="(required)" if default is dataclasses.MISSING else _value(default), paper=pv,
        )
    groups, concept_problems = concept_groups(cls, names)
    problems += concept_problems
    if problems:
        raise ConfigDocError("\n".join(problems))
    summary = inspect.cleandoc(cls.__doc__ or cls.__name__).splitlines()[0]
    concepts = tuple((c, tuple(rows[n] for n in fs)) for c, fs in groups)
    return ClassDoc(cls.__name__, cls.__module__, summary, concepts, paper is not None)


def _cell(text: str) -> str:
    return text.replace("|", "\\|") if text else "—"


def render(classes: Iterable[type] | None = None) -> str:
    """The whole of docs/config.md."""
    docs = [class_doc(c) for c in (config_classes() if classes is None else classes)]
    out = [
        "# Configuration reference",
        "",
        "<!-- Generated by scripts/gen_config_doc.py from the config classes' docstrings; do not edit by hand.",
        "     Regenerate with `python scripts/gen_config_doc.py`; tests/test_config_doc.py fails when this file is stale. -->",
        "",
        "Every setting of the package is a field of a frozen dataclass; change one with `dataclasses.replace`.",
        "Each table lists a class's fields grouped by concept. **Symbol**: the paper's notation where there is one",
        "(or the symbol the field's docstring uses). **Unit**: `—` for a dimensionless number, a count, a flag or a choice.",
        "**Paper**: the value in the class's `paper()` preset, in bold where it differs from the default; `—` where the class",
        "has no paper preset (the paper does not cover it). **Meaning**: the first sentence of the field's docstring",
        "(the docstring in the code has the rest).",
        "",
        "| Class | Module | Fields | Paper preset |",
        "|---|---|---:|---|",
    ]
    for d in docs:
        n = sum(len(rows) for _, rows in d.concepts)
        out.append(f"| [`{d.name}`](#{d.name.lower()}) | `{d.module}` | {n} | {'yes' if d.has_paper else '—'} |")
    for d in docs:
        out += ["", f"## {d.name}", "", f"`{d.module}.{d.name}`: {_cell(_meaning(d.summary))}", ""]
        out += ["| Concept | Field | Symbol | Unit | Default | Paper | Meaning |", "|---|---|---|---|---|---|---|"]
        for concept, rows in d.concepts:
            for i, r in enumerate(rows):
                out.append(
                    f"| {_cell(concept) if i == 0 else ''} | `{r.name}` | {_cell(r.symbol)} | {_cell(r.unit)} | "
                    f"`{_cell(r.default)}` | {_cell(r.paper)} | {_cell(r.meaning)} |"
                )
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if docs/config.md differs from the generated text")
    args = parser.parse_args(argv)
    try:
        text = render()
    except ConfigDocError as exc:
        print(f"config fields not documented as expected:\n{exc}", file=sys.stderr)
        return 2
    if args.check:
        current = DOC.read_text(encoding="utf-8") if DOC.exists() else ""
        if current != text:
            print(f"{DOC.relative_to(ROOT)} is stale: run python scripts/gen_config_doc.py", file=sys.stderr)
            return 1
        print(f"{DOC.relative_to(ROOT)} is up to date")
        return 0
    DOC.write_text(text, encoding="utf-8")
    print(f"wrote {DOC.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
