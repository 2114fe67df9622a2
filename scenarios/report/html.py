"""HTML assembly from Jinja2 templates: escaped tables, heatmap tables, embedded images,
sections, the page.

The templates live in ``scenarios/report/templates`` and are rendered with
autoescaping on, so every value passed in is escaped unless it is
``markupsafe.Markup`` (HTML this module built). The page is one
self-contained file: inline CSS, images as base64 ``data:`` URIs (SVG figures, the
PNG of the rendered grasp) or inline SVG charts, no script and no external address.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import jinja2
from markupsafe import Markup

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1200px; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; }
table { border-collapse: collapse; margin: .6em 0 1.2em; font-size: .85em; }
th, td { border: 1px solid #ccc; padding: .2em .5em; text-align: right; }
th { background: #f2f2f2; } td { white-space: nowrap; }
td.text { white-space: normal; } td.text, th.text { text-align: left; }
caption { caption-side: top; text-align: left; font-weight: bold; padding: .3em 0; }
img { max-width: 100%; height: auto; display: block; margin: .5em 0; }
p.note { color: #666; font-style: italic; }
nav ul { columns: 2; } details { margin: .5em 0; } code { font-size: .85em; }
.bad { color: #b00; font-weight: bold; }
div.row { display: flex; flex-wrap: wrap; gap: .5em; align-items: flex-start; }
div.row img { max-width: 49%; } div.scroll { overflow-x: auto; max-width: 100%; }
figure { margin: .5em 0; } figcaption { font-size: .85em; color: #444; }
div.choices details { border: 1px solid #ddd; border-radius: 3px; padding: .2em .5em; }
div.choices summary { cursor: pointer; } div.choices details[open] summary { font-weight: bold; }
td.lo { color: #666; font-size: .9em; }
p.finding { font-size: 1.15em; line-height: 1.4; border-left: 4px solid #1f77b4;
  padding: .3em .8em; background: #f4f8fc; }
div.row img.half { max-width: 49%; }
svg.chart { max-width: 100%; height: auto; display: block; }
table.heat td { text-align: center; min-width: 3.2em; }
table.heat th { font-weight: normal; }
"""

_ENV = jinja2.Environment(
    loader=jinja2.PackageLoader("scenarios.report", "templates"),
    autoescape=True, undefined=jinja2.StrictUndefined, keep_trailing_newline=False,
)


def render(template: str, **context: Any) -> str:
    """Render one of the report's templates (autoescaped) to an HTML string.

    Plain ``str`` (not ``Markup``), so that the fragments concatenate like
    any string; they are marked safe again where they enter a template.
    """
    return _ENV.get_template(template).render(**context)


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
    return render("table.html.j2", headers=[fmt(h) for h in headers],
                  rows=[[fmt(v) for v in r] for r in rows], caption=caption,
                  text_columns=text_columns)


def img(png: bytes, alt: str) -> str:
    """An ``<img>`` with the PNG embedded as a base64 data URI."""
    data = base64.b64encode(png).decode("ascii")
    return str(Markup('<img src="data:image/png;base64,{}" alt="{}">').format(data, alt))


def svg_img(svg: bytes, alt: str, css_class: str = "") -> str:
    """An ``<img>`` with an SVG document embedded as a base64 data URI (kept apart from the
    page: its ids and styles cannot clash with another figure's)."""
    data = base64.b64encode(svg).decode("ascii")
    return str(Markup('<img{} src="data:image/svg+xml;base64,{}" alt="{}">').format(
        Markup(f' class="{css_class}"') if css_class else "", data, alt))


def figure(chart: str, caption: str = "") -> str:
    """A chart (HTML already built, e.g. an inline SVG) in a ``<figure>`` with a caption."""
    return render("figure.html.j2", chart=Markup(chart), caption=caption)


@dataclass(frozen=True)
class HeatCell:
    """One cell of :func:`heat_table`: its text, the episodes behind it, its colours."""

    text: str
    n: int
    background: str
    color: str


def heat_table(corner: str, columns: Sequence[str], rows: Sequence[tuple[str, Sequence[HeatCell]]],
               caption: str = "") -> str:
    """A small table whose cells are coloured by value (a heatmap that stays text)."""
    return render("heatmap.html.j2", corner=corner, columns=columns, caption=caption,
                  rows=[{"label": label, "cells": cells} for label, cells in rows])


def choices(items: Sequence[tuple[str, str]], open_first: bool = True) -> str:
    """A list of ``<details>`` (summary text, body HTML), one open at a time by the reader."""
    return render("choices.html.j2", open_first=open_first,
                  items=[{"summary": summary, "body": Markup(body)} for summary, body in items])


def side_by_side(items: Sequence[str]) -> str:
    """Items (e.g. images) side by side, wrapping on narrow screens."""
    return '<div class="row">' + "".join(items) + "</div>"


def note(text: str) -> str:
    """A one-line note paragraph."""
    return str(Markup('<p class="note">{}</p>').format(text))


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
    """The whole HTML document (``page.html.j2``)."""
    return render("page.html.j2", title=title, subtitle=subtitle, css=Markup(_CSS),
                  sections=[{"anchor": s.anchor, "title": s.title, "body": Markup(s.body),
                             "omitted": s.omitted} for s in sections]) + "\n"
