"""HTML assembly: escaped tables, embedded PNG images, sections and the page.

The page is one self-contained file: inline CSS, images as base64 ``data:``
URIs, no script and no external address.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: .85em; }
th, td { border: 1px solid #ccc; padding: .2em .5em; text-align: right; }
th { background: #f2f2f2; } td.text, th.text { text-align: left; }
caption { caption-side: top; text-align: left; font-weight: bold; padding: .3em 0; }
img { max-width: 100%; height: auto; display: block; margin: .5em 0; }
p.note { color: #666; font-style: italic; }
nav ul { columns: 2; } details { margin: .5em 0; } code { font-size: .85em; }
.bad { color: #b00; font-weight: bold; }
div.row { display: flex; flex-wrap: wrap; gap: .5em; align-items: flex-start; }
div.row img { max-width: 32%; } div.scroll { overflow-x: auto; max-width: 100%; }
"""


def esc(value: Any) -> str:
    """HTML-escaped text of ``value``."""
    return html.escape(str(value), quote=True)


def fmt(value: Any, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; ``None`` and non-finite as text."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "n/a"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return f"{value:.{digits}g}"
    return str(value)


def pm(mean: float | None, sd: float | None, digits: int = 4) -> str:
    """``"mean ± sd"``."""
    if mean is None:
        return "n/a"
    return f"{fmt(mean, digits)} ± {fmt(sd, digits)}"


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], caption: str = "",
          text_columns: int = 1) -> str:
    """An HTML table (horizontally scrollable); the first ``text_columns`` columns are text.

    Cells are escaped; floats are formatted with :func:`fmt`.
    """
    def cell(tag: str, i: int, value: Any) -> str:
        cls = ' class="text"' if i < text_columns else ""
        return f"<{tag}{cls}>{esc(fmt(value))}</{tag}>"

    head = "".join(cell("th", i, h) for i, h in enumerate(headers))
    body = "\n".join("<tr>" + "".join(cell("td", i, v) for i, v in enumerate(r)) + "</tr>"
                     for r in rows)
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return (f'<div class="scroll"><table>{cap}<thead><tr>{head}</tr></thead><tbody>\n{body}'
            "\n</tbody></table></div>")


def img(png: bytes, alt: str) -> str:
    """An ``<img>`` with the PNG embedded as a base64 data URI."""
    data = base64.b64encode(png).decode("ascii")
    return f'<img src="data:image/png;base64,{data}" alt="{esc(alt)}">'


def side_by_side(items: Sequence[str]) -> str:
    """Items (e.g. images) side by side, wrapping on narrow screens."""
    return '<div class="row">' + "".join(items) + "</div>"


def note(text: str) -> str:
    """A one-line note paragraph."""
    return f'<p class="note">{esc(text)}</p>'


@dataclass(frozen=True)
class Section:
    """One numbered section of the report.

    Attributes
    ----------
    anchor : str
        ``id`` of the heading.
    title : str
        Heading text.
    body : str
        HTML of the content (already escaped).
    omitted : bool
        Whether the section only holds a note that its data is absent.
    """

    anchor: str
    title: str
    body: str
    omitted: bool = False


def page(title: str, subtitle: str, sections: Sequence[Section]) -> str:
    """The whole HTML document."""
    toc = "".join(f'<li><a href="#{esc(s.anchor)}">{esc(s.title)}</a>'
                  f'{" (no data)" if s.omitted else ""}</li>' for s in sections)
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{esc(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{esc(title)}</h1><p>{esc(subtitle)}</p>",
        f"<nav><ul>{toc}</ul></nav>",
    ]
    for s in sections:
        parts.append(f'<section id="{esc(s.anchor)}"><h2>{esc(s.title)}</h2>\n{s.body}</section>')
    parts.append("</body></html>\n")
    return "\n".join(parts)
