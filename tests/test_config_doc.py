"""docs/config.md is what scripts/gen_config_doc.py makes of the config classes, and the generator's rules hold."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from conftest import load_script

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "gen_config_doc.py"


def _load_script():  # noqa: ANN202
    return load_script("gen_config_doc")


gen = _load_script()


def test_docs_config_md_is_up_to_date() -> None:
    current = gen.DOC.read_text(encoding="utf-8")
    assert current == gen.render(), "docs/config.md is stale: run python scripts/gen_config_doc.py"


def test_every_config_class_and_field_is_in_the_table() -> None:
    classes = gen.config_classes()
    names = {c.__name__ for c in classes}
    assert {"AffordanceConfig", "LearningConfig", "SynthesisConfig", "SimConfig", "EnvConfig"} <= names
    text = gen.render(classes)
    for cls in classes:
        assert f"\n## {cls.__name__}\n" in text
        for f in dataclasses.fields(cls):
            assert f"| `{f.name}` |" in text, f"{cls.__name__}.{f.name}"


@dataclasses.dataclass(frozen=True)
class _Toy:
    """Toy settings.

    Fields by concept
    -----------------
    - Geometry: radius
    - Schedule: steps,
      rate
    """

    radius: float = 0.5
    """r [m]: radius of the thing. More prose that the table leaves out."""
    steps: int = 3
    """[—]: how many steps."""
    rate: float = 30.0
    """f [Hz]: λ-free frame rate."""

    @classmethod
    def paper(cls) -> _Toy:
        return cls(radius=0.25)


def test_rows_carry_symbol_unit_default_paper_value_and_first_sentence() -> None:
    doc = gen.class_doc(_Toy)
    assert [c for c, _ in doc.concepts] == ["Geometry", "Schedule"]
    (radius,), (steps, rate) = (rows for _, rows in doc.concepts)
    assert (radius.symbol, radius.unit, radius.default, radius.paper) == ("r", "m", "0.5", "**0.25**")  # differs: bold
    assert radius.meaning == "Radius of the thing."
    assert (steps.symbol, steps.unit, steps.paper) == ("", "—", "3")  # same as the default: plain
    assert (rate.symbol, rate.unit, rate.meaning) == ("f", "Hz", "λ-free frame rate.")  # a symbol keeps its case


def test_without_a_paper_preset_the_paper_column_is_a_dash() -> None:
    @dataclasses.dataclass(frozen=True)
    class NoPaper:
        """No preset."""

        x: int = 1
        """[—]: x."""

    doc = gen.class_doc(NoPaper)
    assert [c for c, _ in doc.concepts] == [gen.ONE_CONCEPT] and doc.concepts[0][1][0].paper == "—"
    assert "| `x` | — | — | `1` | — | X. |" in gen.render([NoPaper])


def test_a_field_without_symbol_and_unit_tag_is_refused() -> None:
    @dataclasses.dataclass(frozen=True)
    class Untagged:
        """Untagged."""

        x: int = 1
        """Just prose."""
        y: int = 2

    with pytest.raises(gen.ConfigDocError, match=r"Untagged\.x: docstring does not start") as info:
        gen.class_doc(Untagged)
    assert "Untagged.y: no docstring" in str(info.value)


def test_the_concept_section_must_name_every_field_once() -> None:
    @dataclasses.dataclass(frozen=True)
    class Grouped:
        """Grouped.

        Fields by concept
        -----------------
        - A: x, x, z
        """

        x: int = 1
        """[—]: x."""
        y: int = 2
        """[—]: y."""

    with pytest.raises(gen.ConfigDocError) as info:
        gen.class_doc(Grouped)
    msg = str(info.value)
    assert "names 'z', which is not a field" in msg
    assert "names 'x' more than once" in msg
    assert "Grouped.y: in no concept" in msg


def test_check_mode_reports_a_stale_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stale = tmp_path / "config.md"
    monkeypatch.setattr(gen, "ROOT", tmp_path)
    monkeypatch.setattr(gen, "DOC", stale)
    stale.write_text("old\n", encoding="utf-8")
    assert gen.main(["--check"]) == 1
    assert gen.main([]) == 0
    assert gen.main(["--check"]) == 0
