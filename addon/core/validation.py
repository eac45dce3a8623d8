# SPDX-License-Identifier: GPL-3.0-or-later
"""Checking a model's parameters against the catalogue (numpy only).

:func:`validate` is what every public entry point calls first (the
reference's ``shade``/``brdf``, the scripting API, the node-group variants):
an unknown model, parameter, choice or combination, or a value out of its
range, raises ``ValueError`` naming what is allowed.
"""

from __future__ import annotations

import numpy as np

from . import catalogue


def check_value(p, value):
    """Check one parameter value against the catalogue; return an array
    (colours get a trailing axis of length 3 or 1)."""
    if p.is_enum:
        if not isinstance(value, str) or value not in p.choices:
            raise ValueError(f"{p.name}={value!r} is not allowed; {p.name} must be {p.allowed()}")
        return value
    if value is None:  # numpy would make it NaN and call it out of range
        raise ValueError(f"{p.name}=None is not allowed; {p.name} must be {p.allowed()}")
    not_allowed = f"{p.name}={value!r} is not allowed; {p.name} must be {p.allowed()}"
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):  # e.g. ragged lists
        raise ValueError(not_allowed) from None
    if raw.dtype.kind not in "iuf":  # numpy would read '20' as 20 and True as 1
        raise ValueError(not_allowed)
    arr = raw.astype(float)
    if np.isnan(arr).any() or (p.minimum is not None and (arr < p.minimum).any()) or (
            p.maximum is not None and (arr > p.maximum).any()):
        bad = arr if arr.ndim == 0 else arr[np.isnan(arr) | (arr < (p.minimum if p.minimum is not None else -np.inf))
                                            | (arr > (p.maximum if p.maximum is not None else np.inf))].ravel()[0]
        raise ValueError(f"{p.name}={float(bad)!r} is out of range; {p.name} must be {p.allowed()}")
    if p.kind == "color":
        if arr.ndim == 0:
            arr = arr[None]  # grey
        elif arr.shape[-1] not in (1, 3):  # RGBA, say: which axis is the colour's is unknown
            raise ValueError(f"{p.name} has shape {arr.shape}; {p.name} must be a scalar (grey), "
                             "an RGB triple, or an array whose last axis has length 3 (RGB) "
                             "or 1 (grey)")
    return arr


def validate(model_name, params):
    """Resolve a model or preset and validate ``params``.

    Returns ``(model, values, given)``: every parameter's checked value
    (defaults filled in) and the set of names the caller gave.
    """
    model, fixed, preset_defaults = catalogue.resolve(model_name)
    allowed = [n for n in model.param_names if n not in fixed]
    for key in params:
        if key in fixed:
            raise ValueError(f"{key} is fixed to {fixed[key]!r} by the preset {model_name!r}; "
                             f"allowed parameters: {', '.join(allowed)}")
        if key not in model.param_names:
            raise ValueError(f"unknown parameter {key!r} for model {model_name!r}; "
                             f"allowed: {', '.join(allowed)}")
    given = set(params)
    merged = {p.name: p.default for p in model.params}
    merged.update(preset_defaults)
    merged.update(fixed)
    merged.update(params)
    values = {p.name: check_value(p, merged[p.name]) for p in model.params}
    if "width" in model.rules:
        _check_width(model_name, values, given)
    if "smith_1967_beckmann" in model.rules and values["shadowing"] == "smith_1967" \
            and values["distribution"] != "beckmann":
        raise ValueError("shadowing='smith_1967' (the slide's erfc bracket form) is defined for "
                         "distribution='beckmann' only; allowed shadowing for "
                         f"{values['distribution']!r}: none, smith, smith_correlated, vgroove")
    return model, values, given


def _check_width(model_name, values, given):
    widths = [g for g in (("beta",), ("alpha",), ("alpha_x", "alpha_y")) if any(n in given for n in g)]
    if len(widths) > 1:
        raise ValueError(f"give one width for {model_name!r}: beta, alpha, or alpha_x with alpha_y "
                         f"(got {', '.join(sorted(n for g in widths for n in g))})")
    native = widths and widths[0][0] != "beta"
    if native and values["distribution"] not in ("trowbridge_reitz", "beckmann"):
        raise ValueError(f"alpha/alpha_x/alpha_y are native widths of 'trowbridge_reitz' and "
                         f"'beckmann' only; distribution {values['distribution']!r} takes beta")
    if widths and widths[0] == ("alpha_x", "alpha_y") and not {"alpha_x", "alpha_y"} <= given:
        raise ValueError("give alpha_x and alpha_y together (anisotropic width)")
    values["_width"] = widths[0][0] if widths else "beta"
