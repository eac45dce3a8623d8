# SPDX-License-Identifier: GPL-3.0-or-later
"""The documentation generated from the catalogue: the README's model table
and one page per model (``docs/models/<id>.md``) that gathers the model's
faces -- its parameters, formula, citation, the reference function that
judges it, the description its shaders and node graphs are generated from,
its shaders, its node groups, its tests -- and its measured error per
backend and mode from the last ``make demo`` (``docs/models/measured.json``).

``python -m tools.gen_docs`` writes them; a test fails when a page is stale
or a face is missing.
"""

from __future__ import annotations

import inspect
import json
import re
from pathlib import Path

from addon.core import catalogue, variants
from addon.core.formulas import models as formulas
from addon.core.reference import models as reference_models

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MODEL_DOCS = ROOT / "docs" / "models"
MEASURED = MODEL_DOCS / "measured.json"
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


def _param_rows(params, with_model=None):
    rows = []
    for i, p in enumerate(params):
        unit = " (rad)" if p.kind == "angle" else ""
        first = f"| `{with_model}` " if with_model is not None and i == 0 else \
            ("| " if with_model is not None else "")
        rows.append(f"{first}| `{p.name}`{unit} | {p.description} | {_value(p, p.default)} "
                    f"| {_range(p)} |")
    return rows


def render_models() -> str:
    """The README's table of models and parameters."""
    lines = ["| model | parameter | meaning | default | allowed |", "|---|---|---|---|---|"]
    for m in catalogue.MODELS.values():
        lines += _param_rows(m.params, with_model=m.id)
    lines.append("")
    lines.append("Presets (microfacet with fixed structure):")
    lines.append("")
    for p in catalogue.PRESETS.values():
        fixed = ", ".join(f"{k}=`{v}`" for k, v in p.fixed.items())
        lines.append(f"- `{p.id}`: {p.description} ({fixed}).")
    lines.append("")
    lines.append("One page per model, with its formula, citation, the code of each of its "
                 "faces and its measured error: "
                 + ", ".join(f"[`{m}`](docs/models/{m}.md)" for m in catalogue.MODELS) + ".")
    return "\n".join(lines)


def render_readme(readme: str) -> str:
    start = readme.index(BEGIN) + len(BEGIN)
    end = readme.index(END)
    return readme[:start] + "\n" + render_models() + "\n" + readme[end:]


# --------------------------------------------------------------------------
# The faces of a model

def _line_of(path: Path, pattern: str) -> int:
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if re.search(pattern, line):
            return i
    raise LookupError(f"{pattern!r} not in {path}")


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def faces(model_id: str) -> dict:
    """Each face of a model: name -> ``(repository path, line, what)``.
    Raises LookupError when one is missing."""
    from addon.backends.osl import generate

    model = catalogue.MODELS[model_id]
    out = {}
    ref_file = Path(inspect.getsourcefile(reference_models))
    if not model.reference or not callable(getattr(reference_models, model.reference, None)):
        raise LookupError(f"{model_id}: no reference function {model.reference!r}")
    out["reference"] = (_rel(ref_file), _line_of(ref_file, rf"^def {model.reference}\("),
                        f"`addon.reference` {model.reference}")
    formula = formulas.FORMULAS.get(model_id)
    if formula is None:
        raise LookupError(f"{model_id}: no formula description")
    f_file = Path(inspect.getsourcefile(formulas))
    cls = type(formula).__name__
    out["formula"] = (_rel(f_file), _line_of(f_file, rf"^class {cls}\("),
                      f"the description `{cls}` (exact value, terms, closures)")
    for closure_only in (False, True):
        name = generate.shader_name(model_id, closure_only)
        path = generate.SHADERS / f"{name}.osl"
        if not path.is_file():
            raise LookupError(f"{model_id}: no shader {path}")
        out["shader_bsdf" if closure_only else "shader"] = (
            _rel(path), 1, f"OSL `{name}` ({'path-traced closure' if closure_only else 'exact'})")
    v_file = ROOT / "addon" / "core" / "variants.py"
    out["node_group"] = (_rel(v_file), _line_of(v_file, r"^def group_name\("),
                         f"node group `{variants.group_name(model_id)}` and its variants")
    tests = sorted(p for p in (ROOT / "tests").glob("test_*.py")
                   if f'"{model_id}"' in p.read_text(encoding="utf-8"))
    if not tests:
        raise LookupError(f"{model_id}: no test names it")
    out["tests"] = [(_rel(p), 1, p.stem) for p in tests]
    return out


def _measured(model_id: str) -> list:
    if not MEASURED.is_file():
        return []
    data = json.loads(MEASURED.read_text(encoding="utf-8"))
    return [row for row in data.get("rows", []) if row["model"] == model_id
            or catalogue.PRESETS.get(row["model"]) and
            catalogue.PRESETS[row["model"]].base == model_id]


def render_model_page(model_id: str) -> str:
    model = catalogue.MODELS[model_id]
    f = faces(model_id)
    formula = formulas.FORMULAS[model_id]
    doc = inspect.getdoc(type(formula)) or model.description
    lines = [f"# {model.label} (`{model_id}`)", "",
             "<!-- GENERATED by report/docs.py (python -m tools.gen_docs): do not edit. -->", "",
             model.description + ".", "",
             f"**Slide:** {model.slide}.  ", f"**Citation:** {model.citation}.", "",
             "## Formula", "", doc, "",
             "## Parameters", "",
             "| parameter | meaning | default | allowed |", "|---|---|---|---|"]
    lines += _param_rows(model.params)
    presets = [p for p in catalogue.PRESETS.values() if p.base == model_id]
    if presets:
        lines += ["", "Presets: " + "; ".join(
            f"`{p.id}` ({p.description}; " + ", ".join(f"{k}=`{v}`" for k, v in p.fixed.items())
            + ")" for p in presets) + "."]
    lines += ["", "## Its faces", ""]
    labels = {"reference": "Reference (the judge)", "formula": "Renderer-side description",
              "shader": "Shader", "shader_bsdf": "Shader", "node_group": "Node group"}
    for key in ("reference", "formula", "shader", "shader_bsdf", "node_group"):
        path, line, what = f[key]
        lines.append(f"- {labels[key]}: {what}: [`{path}`](../../{path}#L{line})")
    lines.append("- Tests: " + ", ".join(f"[`{p}`](../../{p})" for p, _l, _n in f["tests"]))
    lines += ["", "## Measured error", ""]
    rows = _measured(model_id)
    if not rows:
        lines.append("Not measured yet: run `make demo`.")
    else:
        meta = json.loads(MEASURED.read_text(encoding="utf-8"))
        lines.append(f"From `make demo` ({meta.get('blender', '?')}): the largest relative "
                     "error over the gonioreflectometer's pixels, and the largest absolute "
                     "difference over the peak.")
        lines += ["", "| variant | backend | mode | status | max rel error | max abs / peak "
                  "| tolerance |", "|---|---|---|---|---|---|---|"]
        for r in rows:
            tol = "measured only" if r["tolerance"] is None else f"{r['tolerance']:g}"
            lines.append(f"| {r['variant']} | {r['backend']} | {r['mode']} | {r['status']} | "
                         f"{r['max_rel_error']:.2e} | {r['max_abs_over_peak']:.2e} | {tol} |")
    return "\n".join(lines) + "\n"


def measured_rows(checks, blender: str) -> dict:
    """What ``make demo`` keeps for the model pages: per gonio check, the
    model, variant, backend, mode, status and errors."""
    rows = []
    for c in checks:
        v = c.values
        if v.get("mode") not in ("exact", "path_traced"):
            continue
        rows.append({"model": v["model"], "variant": v["variant"],
                     "backend": v.get("backend", "osl"), "mode": v["mode"],
                     "status": v["status"], "max_rel_error": v["max_rel_error"],
                     "max_abs_over_peak": v["max_abs_over_peak"], "tolerance": v["tolerance"]})
    return {"blender": blender, "rows": rows}


def outputs() -> dict:
    """Every generated documentation file: path -> text."""
    files = {README: render_readme(README.read_text(encoding="utf-8"))}
    for model_id in catalogue.MODELS:
        files[MODEL_DOCS / f"{model_id}.md"] = render_model_page(model_id)
    return files


def write() -> list:
    written = []
    MODEL_DOCS.mkdir(parents=True, exist_ok=True)
    for path, text in outputs().items():
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
            written.append(path)
    return written
