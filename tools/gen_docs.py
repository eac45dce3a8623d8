# SPDX-License-Identifier: GPL-3.0-or-later
"""Regenerate the catalogue-driven parts of README.md (``python -m tools.gen_docs``).

The text between ``<!-- BEGIN models -->`` and ``<!-- END models -->`` is the
table of models and parameters, rendered from ``addon/catalogue.py``.  A test
fails when the README is out of date.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from addon import catalogue  # noqa: E402

README = ROOT / "README.md"
BEGIN, END = "<!-- BEGIN models -->", "<!-- END models -->"


def _value(p, v):
    if p.kind == "angle":
        return f"{v / catalogue.DEG:g}°"
    if isinstance(v, tuple):
        return "(" + ", ".join(f"{x:g}" for x in v) + ")"
    if isinstance(v, str):
        return f"`{v!r}`"
    return f"{v:g}"


def _range(p):
    if p.is_enum:
        return ", ".join(f"`{c}`" for c in p.choices)
    if p.minimum is None:
        return ""
    return f"[{_value(p, p.minimum)}, {_value(p, p.maximum)}]"


def render_models() -> str:
    lines = ["| model | parameter | meaning | default | allowed |", "|---|---|---|---|---|"]
    for m in catalogue.MODELS.values():
        first = True
        for p in m.params:
            name = f"`{m.id}`" if first else ""
            unit = " (rad)" if p.kind == "angle" else ""
            lines.append(f"| {name} | `{p.name}`{unit} | {p.description} | {_value(p, p.default)} "
                         f"| {_range(p)} |")
            first = False
    lines.append("")
    lines.append("Presets (microfacet with fixed structure):")
    lines.append("")
    for p in catalogue.PRESETS.values():
        fixed = ", ".join(f"{k}=`{v}`" for k, v in p.fixed.items())
        lines.append(f"- `{p.id}`: {p.description} ({fixed}).")
    return "\n".join(lines)


def render(readme: str) -> str:
    start = readme.index(BEGIN) + len(BEGIN)
    end = readme.index(END)
    return readme[:start] + "\n" + render_models() + "\n" + readme[end:]


def main() -> int:
    text = README.read_text()
    new = render(text)
    if new != text:
        README.write_text(new)
        print("updated README.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
