# SPDX-License-Identifier: GPL-3.0-or-later
"""The report's pages as jinja2 templates (HTML escaped by default; figures
are inserted with ``|safe``)."""

from __future__ import annotations

from pathlib import Path

import jinja2

_ENV = jinja2.Environment(
    loader=jinja2.FileSystemLoader(str(Path(__file__).resolve().parent)),
    autoescape=jinja2.select_autoescape(["html"]),
    trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)


def _fmt(x, spec=".2e"):
    if x is None:
        return "—"
    if isinstance(x, float) and x != x:
        return "—"
    return format(x, spec)


_ENV.filters["fmt"] = _fmt


def render(name: str, **context) -> str:
    return _ENV.get_template(name).render(**context)
