# SPDX-License-Identifier: GPL-3.0-or-later
"""Where each shipped microfacet mixture holds the fitted bound, width by
width, without and with the model's Fresnel (``python -m tools.fit
--bounds``, the last step of ``make fit``).

:func:`fitting.mixtures.measure` gives a variant one number, its worst
width: one wide interval over the bound made the whole variant "approx",
and so did any Fresnel, because the fits are made for F = 1.  Here the
shipped mixtures (:mod:`addon.core.fits.mixtures`, read back as the
shaders evaluate them) are measured interval by interval of their width
nodes: at both nodes and seven points between them (every eighth), at
views every 1.25 deg up to 70 deg (at every 2.5 deg, views between them
measured up to 0.002 more), lights up to 70 deg (the fitter's light sets,
and the edge of the domain, :func:`edge_lights`), the largest |mixture -
model| over the model's peak there
(:data:`addon.core.formulas.models.FIT_BOUND` is the bound it is compared
with).

The fitter's light sets are the mirror images of a grid of half vectors,
which reach the domain's edge (lights at 70 deg) only here and there, and
the error is often largest on it, at grazing lights.  Without the edge
the measure missed up to 0.004 of the peak there (Blinn with separable
Smith as shipped before its edge step, beta 73.8 deg: 0.0250 at the 70
deg view, 0.0289 on the edge), and
rose and fell by up to 0.002 from one view to the next, 0.3125 deg apart,
as the grid's lights came near the edge and left it.

With Fresnel the model is F(L.H) times the model without it (the
reference's microfacet BRDF), and so is each microfacet member, which
carries the model's Fresnel at its own half vector, the same one; the
diffuse member, which has none, is weighted by F at the mean L.H of the
lights it reflects (:func:`addon.core.formulas.library.mean_light_half_cosine`).
So for one interval and one Fresnel the measure needs no new closure
values, only F; it is taken for every index on a grid of each class, per
colour channel against that channel's own peak, and the class keeps the
worst:

- ``dielectric``: a real index n from 1 to 10 in every channel
  (:data:`DIELECTRIC`; F is 0 at n = 1, the grid starts just above);
- ``conductor``: a complex index n + ik with k >= 1.5 in every channel, n
  over the catalogue's range (:data:`CONDUCTOR`; every metal of
  ``catalogue.METALS`` is in it).

Anything else (a dielectric index below 1, a conductor with k under 1.5
in some channel) is not measured here: "approx"
(:func:`addon.core.formulas.mixtures.fresnel_class` sorts a choice into
its class).

Deterministic (no random widths).  Its output, ``addon/core/fits/bounds.py``,
names what it was computed from (:func:`fitter_hash`).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from addon.core import catalogue
from addon.core.formulas import library as L
from addon.core.reference import fresnel as FR

from . import mixtures as M
from .joint import fresnel_cosines, with_edge

POINTS = 8  # each interval at every eighth of it, both nodes included
VIEW_STEP_DEG = 1.25
VIEWS_DEG = tuple(VIEW_STEP_DEG * i for i in range(57))  # 0 to 70 deg
EDGE_AZIMUTHS = 181  # lights on the domain's edge (70 deg), every degree of azimuth
DIELECTRIC = (1.001, 1.05, 1.1, 1.2, 1.33, 1.5, 1.7, 2.0, 2.5, 3.0, 4.0, 6.0, 10.0)
DIELECTRIC_RANGE = (1.0, catalogue.MODELS["microfacet"].param("ior").maximum)
CONDUCTOR_N = (0.01, 0.05, 0.1, 0.2, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
CONDUCTOR_K = (1.5, 2.0, 3.0, 5.0, 10.0, 20.0)
CONDUCTOR = tuple((n, k) for n in CONDUCTOR_N for k in CONDUCTOR_K)
CONDUCTOR_K_MIN = CONDUCTOR_K[0]
CLASSES = ("none", "dielectric", "conductor")


def fresnel_settings(cls):
    """F(c) for each index of a class's grid."""
    if cls == "none":
        return [lambda c: np.ones_like(c)]
    if cls == "dielectric":
        return [lambda c, n=n: FR.F_dielectric(c, n) for n in DIELECTRIC]
    return [lambda c, n=n, k=k: FR.F_conductor(c, n, k) for n, k in CONDUCTOR]


def rows_at(fit, value):
    """At one width, per view: L.H of each light and the diffuse member's
    mean L.H (:func:`.joint.fresnel_cosines`), the microfacet members'
    sum, the diffuse member's part and the model, each without Fresnel."""
    t = fit.target
    d = list(t.members).index("diffuse")
    edge = edge_lights()
    rows = []
    for deg in VIEWS_DEG:
        c = math.cos(math.radians(deg))
        s = M.samples(t, float(value), c)
        alphas, w = M.evaluate_series(fit, float(value), c)
        A, _a = M._block(s, t.members, alphas)
        wi, A, model = with_edge(t, float(value), s, A, alphas, edge)
        wd = np.where(np.arange(len(w)) == d, 0.0, w)
        rows.append((*fresnel_cosines(wi, s.wo, c), A @ wd, A[:, d] * w[d], model))
    return rows


def edge_lights(n=EDGE_AZIMUTHS, offset=0.0):
    """Lights on the edge of the measured domain, at 70 deg from the normal
    (:data:`.mixtures.FIT_VIEW`), at ``n`` azimuths over [0, pi], every
    degree by default (the view lies in the x-z plane: the other half is
    its mirror image); ``offset``: the azimuths moved by that fraction of
    a step (:func:`.assemble.finish_edge` solves at others than these).  The
    fitter's light set reaches that edge only where its half-vector grid
    happens to, and the error is often largest there: Blinn with separable
    Smith as shipped before its edge step, at beta 73.8 deg, view 70 deg,
    0.0250 of the peak on the light set alone and 0.0289 on the edge."""
    phi = (np.arange(n) + offset) * math.pi / (n - 1)
    phi = phi[phi <= math.pi + 1e-12]
    s, c = math.sin(M.FIT_VIEW), math.cos(M.FIT_VIEW)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.full_like(phi, c)], -1)


def setting_errors(rows, cls, diffuse_exact=False):
    """The largest error over the peak for each index of a class's grid
    (in :func:`fresnel_settings`' order).  ``diffuse_exact``: as if the
    diffuse member carried F(L.H) light by light as the others do (no
    Cycles closure does; what the diffuse member's Fresnel costs,
    ``python -m fitting.limits --fresnel``)."""
    out = []
    for F in fresnel_settings(cls):
        err = peak = 0.0
        for cd, cbar, micro, diffuse, model in rows:
            Fh = F(cd)
            Fd = Fh if diffuse_exact else F(np.array(cbar))
            err = max(err, float(np.max(np.abs(Fh * (micro - model) + Fd * diffuse))))
            peak = max(peak, float(np.max(Fh * model)))
        out.append(err / peak)
    return out


def class_error(rows, cls, diffuse_exact=False):
    """The largest error over the peak for the worst index of a class's
    grid (:func:`setting_errors`)."""
    return max(setting_errors(rows, cls, diffuse_exact))


def worst_settings(fit, only, picked=None):
    """For each Fresnel class, F for the index of its grid that errs most
    at some point of the intervals ``only`` (as :func:`intervals` measures
    them), each index once: the ones :func:`.assemble.finish_edge` holds
    in its programme.  ``picked``: those indices as :func:`intervals`
    recorded them for ``fit`` (its ``picked``), instead of measuring the
    intervals again."""
    if picked is None:
        picked = {}
        intervals(fit, only=only, picked=picked)
    chosen = set().union(*(picked.get(j, set()) for j in only))
    return [fresnel_settings(cls)[i] for cls, i in sorted(chosen)]


def _point_indices(fit, value):
    """At one width, for each class: the largest error over the peak and
    the index of the class's grid that makes it."""
    rows = rows_at(fit, value)
    out = {}
    for cls in CLASSES:
        errors = setting_errors(rows, cls)
        out[cls] = (max(errors), int(np.argmax(errors)))
    return out


def _point(fit, value):
    """At one width: for each class, the largest error over the peak (the
    worst index of the class's grid)."""
    return {cls: e for cls, (e, _i) in _point_indices(fit, value).items()}


def intervals(fit, only=None, picked=None):
    """Per class, the bound of each interval between the fit's width nodes
    (the largest of its nine points); up to the closures' range
    (``target.soft_max``, alpha 1: wider is approx anyway): the interval
    that straddles it is measured up to it, those beyond are left out
    (None).  ``only``: the intervals to measure, the others None too
    (:func:`.assemble.finish_edge` measures those a window's nodes reach).
    ``picked``: a dict that gets, for each interval measured, the set of
    ``(class, index)`` of the Fresnel classes' worst grid indices at its
    points (:func:`worst_settings`)."""
    nodes = fit.width_values
    soft = fit.target.soft_max
    points = {}
    out = {cls: [] for cls in CLASSES}
    for j in range(len(nodes) - 1):
        a, b = float(nodes[j]), min(float(nodes[j + 1]), soft)
        if a >= soft - 1e-12 or (only is not None and j not in only):
            for cls in CLASSES:
                out[cls].append(None)
            continue
        worst = dict.fromkeys(CLASSES, 0.0)
        indices = set()
        for i in range(POINTS + 1):
            x = a + (b - a) * i / POINTS
            key = round(x, 12)
            if key not in points:
                points[key] = _point_indices(fit, x)
            for cls in CLASSES:
                worst[cls] = max(worst[cls], points[key][cls][0])
            indices.update((cls, points[key][cls][1]) for cls in CLASSES[1:])
        for cls in CLASSES:
            out[cls].append(worst[cls])
        if picked is not None:
            picked[j] = indices
    return out


def keys():
    """The microfacet variants with a shipped mixture."""
    from addon.core.fits import mixtures as data
    return [k for k in data.FITS if k.startswith("microfacet/")]


def measure_key(key):
    fit = M.load_fits([key])[key]
    return {"width": fit.target.width, "nodes": tuple(float(x) for x in fit.width_values),
            "bounds": intervals(fit)}


def fitter_hash() -> str:
    """This module, the shipped mixtures it measures and the diffuse
    member's Fresnel angle."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for rel in ("fitting/bounds.py", "addon/core/fits/mixtures.py"):
        h.update((root / rel).read_bytes())
    h.update(repr(L.MEAN_LIGHT_HALF_COSINE).encode())
    return h.hexdigest()[:16]


def module_text(measured: dict) -> str:
    lines = [
        "# SPDX-License-Identifier: GPL-3.0-or-later\n",
        "# GENERATED by fitting/bounds.py (python -m tools.fit --bounds): do not edit.\n",
        '"""Per width interval of each microfacet mixture, the largest |mixture -\n',
        "model| over the peak (views and lights up to 70 deg), without Fresnel\n",
        "('none') and with the worst index of each Fresnel class\n",
        "('dielectric', 'conductor'); None beyond the closures' range.  See\n",
        'fitting/bounds.py."""\n\n',
        f"FITTER = {fitter_hash()!r}\n",
        f"DIELECTRIC_RANGE = {DIELECTRIC_RANGE!r}\n",
        f"CONDUCTOR_K_MIN = {CONDUCTOR_K_MIN!r}\n",
        f"VIEW_STEP_DEG = {VIEW_STEP_DEG!r}  # the views measured: every this, to 70 deg\n",
        "BOUNDS = {\n"]
    for key in sorted(measured):
        m = measured[key]
        lines.append(f"    {key!r}: {{\n        'width': {m['width']!r},\n")
        lines.append(f"        'nodes': {tuple(m['nodes'])!r},\n")
        for cls in CLASSES:
            # rounded up: a bound is never written below what was measured
            values = tuple(None if v is None else math.ceil(v * 1e5) / 1e5
                           for v in m["bounds"][cls])
            lines.append(f"        {cls!r}: {values!r},\n")
        lines.append("    },\n")
    lines.append("}\n")
    return "".join(lines)
