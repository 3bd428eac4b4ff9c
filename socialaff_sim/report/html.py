"""Building blocks of the HTML reports: escaping, tables, figures, videos and the page itself.

A report is one ``report.html`` beside the images and videos it shows (relative links), so the
folder can be moved or zipped whole. No scripts, no external resources: it opens offline.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from pathlib import Path

from .._atomic import atomic_write_text

__all__ = ["Cell", "Page", "esc", "fmt", "table", "figure", "video", "definitions"]

Cell = str | int | float | None
"""A table cell: text (escaped), a number (formatted), ``None`` (shown as a dash)."""

_CSS = """
:root { --ink: #1d2329; --muted: #5b6670; --line: #d5dbe0; --band: #f3f6f8; --accent: #1f6f8b;
        --good: #1b7a3a; --bad: #b3261e; }
* { box-sizing: border-box; }
body { margin: 0; font: 16px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
       color: var(--ink); background: #fff; }
main { max-width: 1120px; margin: 0 auto; padding: 24px 28px 64px; }
header.top { background: var(--band); border-bottom: 1px solid var(--line); }
header.top > div { max-width: 1120px; margin: 0 auto; padding: 20px 28px 14px; }
h1 { font-size: 1.7rem; margin: 0 0 4px; }
h2 { font-size: 1.3rem; margin: 36px 0 10px; padding-bottom: 4px; border-bottom: 2px solid var(--line); }
h3 { font-size: 1.08rem; margin: 22px 0 8px; }
p.lead { color: var(--muted); margin: 0; max-width: 80ch; }
p, li { max-width: 86ch; }
nav a { margin-right: 14px; color: var(--accent); text-decoration: none; font-weight: 600; }
table { border-collapse: collapse; margin: 8px 0 6px; font-variant-numeric: tabular-nums; }
p.caption { color: var(--muted); margin: 14px 0 4px; font-size: 0.95rem; }
th, td { border-bottom: 1px solid var(--line); padding: 5px 12px; text-align: left; vertical-align: top; }
th { background: var(--band); font-weight: 600; }
td.num { text-align: right; }
td.best { font-weight: 700; }
td.yes { color: var(--good); font-weight: 600; }
td.no { color: var(--bad); font-weight: 600; }
figure { margin: 14px 0 20px; }
figure img, figure video { max-width: 100%; height: auto; border: 1px solid var(--line); border-radius: 4px; display: block; }
figcaption { color: var(--muted); font-size: 0.92rem; margin-top: 6px; max-width: 86ch; }

dl { display: grid; grid-template-columns: max-content auto; gap: 2px 16px; margin: 8px 0; }
dt { color: var(--muted); }
dd { margin: 0; }
.note { color: var(--muted); font-size: 0.92rem; }
code { background: var(--band); padding: 0 4px; border-radius: 3px; }
"""


def esc(text: object) -> str:
    """HTML-escaped ``str(text)``."""
    return html.escape(str(text), quote=True)


def fmt(value: Cell, digits: int = 3, signed: bool = False) -> str:
    """A cell's text: numbers with ``digits`` decimals (and a sign with ``signed``), NaN and ``None`` as a dash."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:+.{digits}f}" if signed else f"{value:.{digits}f}"
    return str(value)


def table(
    header: Sequence[str],
    rows: Sequence[Sequence[Cell]],
    *,
    caption: str = "",
    digits: int = 3,
    best: Sequence[set[int]] | None = None,
    signed: bool = False,
) -> str:
    """A table; numbers right-aligned (signed with ``signed``). ``best[j]`` holds the row indices to bold in column ``j``."""
    out = [f"<p class=\"caption\">{esc(caption)}</p>"] if caption else []
    out.append("<table>")
    out.append("<thead><tr>" + "".join(f"<th scope=\"col\">{esc(h)}</th>" for h in header) + "</tr></thead><tbody>")
    for i, row in enumerate(rows):
        cells = []
        for j, value in enumerate(row):
            classes = []
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                classes.append("num")
            if isinstance(value, bool):
                classes.append("yes" if value else "no")
            if best is not None and j < len(best) and i in best[j]:
                classes.append("best")
            cls = f" class=\"{' '.join(classes)}\"" if classes else ""
            cells.append(f"<td{cls}>{esc(fmt(value, digits, signed))}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    return "\n".join(out)


def figure(src: str, caption: str, *, alt: str = "", link: bool = False) -> str:
    """An image (path relative to the page) with its caption; ``link``: the image links to itself (its full size)."""
    img = f"<img src=\"{esc(src)}\" alt=\"{esc(alt or caption)}\">"
    if link:
        img = f"<a href=\"{esc(src)}\">{img}</a>"
    return f"<figure>{img}<figcaption>{esc(caption)}</figcaption></figure>"


def video(src: str, caption: str, *, poster: str | None = None, width: int | None = None) -> str:
    """A video that plays inline (muted, looping) with controls, and its caption."""
    attrs = f" poster=\"{esc(poster)}\"" if poster else ""
    attrs += f" width=\"{width}\"" if width else ""
    return (f"<figure><video src=\"{esc(src)}\" controls autoplay muted loop playsinline preload=\"auto\"{attrs}>"
            f"<a href=\"{esc(src)}\">{esc(src)}</a></video><figcaption>{esc(caption)}</figcaption></figure>")


def definitions(items: Sequence[tuple[str, Cell]]) -> str:
    """A two-column list of names and values."""
    return "<dl>" + "".join(f"<dt>{esc(k)}</dt><dd>{esc(fmt(v))}</dd>" for k, v in items) + "</dl>"


class Page:
    """An HTML page assembled from sections; :meth:`write` saves it atomically."""

    def __init__(self, title: str, lead: str) -> None:
        self.title = title
        self.lead = lead
        self._sections: list[tuple[str, str, str]] = []

    def section(self, anchor: str, heading: str, body: str) -> None:
        """Append a section; ``anchor`` names it in the page's navigation."""
        self._sections.append((anchor, heading, body))

    def render(self) -> str:
        """The whole document."""
        nav = " ".join(f"<a href=\"#{esc(a)}\">{esc(h)}</a>" for a, h, _ in self._sections)
        body = "\n".join(f"<section id=\"{esc(a)}\"><h2>{esc(h)}</h2>\n{b}\n</section>" for a, h, b in self._sections)
        return (
            "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>{esc(self.title)}</title>\n<link rel=\"icon\" href=\"data:,\">\n<style>{_CSS}</style>\n</head>\n<body>\n"
            f"<header class=\"top\"><div><h1>{esc(self.title)}</h1><p class=\"lead\">{esc(self.lead)}</p>"
            f"<nav>{nav}</nav></div></header>\n<main>\n{body}\n</main>\n</body>\n</html>\n"
        )

    def write(self, path: str | Path) -> Path:
        """Write the page to ``path`` (atomically); returns the path."""
        path = Path(path)
        atomic_write_text(path, self.render())
        return path
