# SPDX-License-Identifier: GPL-3.0-or-later
"""The generated documentation: the README's model table and one page per
model gathering its faces; stale pages and missing faces fail."""

import re
from pathlib import Path

import numpy as np
import pytest

from addon import catalogue
from report import docs

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("path", sorted(docs.outputs()), ids=lambda p: p.name)
def test_generated_documentation_is_up_to_date(path):
    assert path.read_text(encoding="utf-8") == docs.outputs()[path], "run: python -m tools.gen_docs"


def test_readme_lists_every_model():
    text = docs.README.read_text(encoding="utf-8")
    for model in catalogue.MODELS:
        assert f"`{model}`" in text and f"docs/models/{model}.md" in text


@pytest.mark.parametrize("model_id", list(catalogue.MODELS))
def test_every_model_has_all_its_faces(model_id):
    """Reference function, formula description, both shaders, the native
    node emitter, node group and tests: each exists where its page links."""
    f = docs.faces(model_id)
    assert set(f) == {"reference", "formula", "shader", "shader_bsdf", "native", "node_group",
                      "tests"}
    for key, target in f.items():
        for path, line, _what in (target if key == "tests" else [target]):
            text = (ROOT / path).read_text(encoding="utf-8").splitlines()
            assert 1 <= line <= len(text), (key, path, line)


def test_a_missing_face_is_reported(monkeypatch):
    from addon.core.formulas import models as formulas
    monkeypatch.delitem(formulas.FORMULAS, "ward")
    with pytest.raises(LookupError, match="no formula"):
        docs.faces("ward")


def test_the_docs_quote_the_fitters_words():
    """report/docs.py finds what each variant's data went through by the
    fitter's own words in what it ships (SHIPPED); a reworded step would
    drop out of the docs silently."""
    from fitting import assemble, reparam
    assert docs.JOINT == assemble.JOINT and docs.DERIVED == reparam.DERIVED
    assert docs.MOVED == assemble.MOVED


def readme_python_blocks() -> list:
    """The README's ```python blocks, in order."""
    text = docs.README.read_text(encoding="utf-8")
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_the_readmes_reference_example_runs_as_written():
    """The README's first example, run as a user would paste it: the values
    it computes are the reference's, finite and positive (a conductor's
    highlight and Phong's lobe near the mirror direction)."""
    block = readme_python_blocks()[0]
    assert "from addon import reference" in block
    names = {}
    exec(compile(block, "README.md", "exec"), names)
    assert names["rgb"].shape == (3,) and np.all(np.isfinite(names["rgb"]))
    assert np.all(names["rgb"] > 0) and np.all(names["f_r"] > 0)
