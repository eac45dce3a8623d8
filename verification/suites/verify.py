# SPDX-License-Identifier: GPL-3.0-or-later
"""Verification runs on the virtual gonioreflectometer and the white furnace.

Every check renders a material built through the public API (``api`` is the
extension's ``api`` module: ``addon.api`` in the tests, the *installed*
``bl_ext.<repo>.reflection_models.api`` in the demo) and compares it with an
expectation that never comes from a render:

- :func:`run_case`: one case of :mod:`.cases` in ``"exact"`` mode
  (the ``Direct`` output: the model evaluated in OSL for the scene's sun) or
  ``"path_traced"`` mode (the ``BSDF`` output: Cycles closures lit by the
  same delta sun, direct light only, one sample) against
  ``addon.reference.shade`` on the scene's analytic geometry.
- :func:`run_oracle`: the exact-mode microfacet against Blender's *native*
  Glossy BSDF (an implementation we did not write) on the same scene.
- :func:`run_furnace`: the path-traced output of energy-normalised models in
  the white furnace reflects at most what it receives.

Every function returns a :class:`~verification.harness.checks.Check`
(``passed``: True, False, or None when no tolerance is claimed) whose
``values`` hold ``model``, ``variant``, ``mode``, ``status``,
``max_rel_error``, ``rms_rel_error``, ``tolerance`` and diagnostic fields,
and whose ``images`` hold the per-light arrays for the report.

The relative error of a pixel channel is ``|render - expected| /
max(|expected|, 1e-3 * peak)`` (``common.compare``), over the gonio mask
(lit or unlit pixels at least one pixel inside a tile, not in a shadow).
``max_abs_over_peak`` (gonio checks) is the largest absolute difference over
the brightest expected value: for an approximation, how visible the
difference is, where the relative error is dominated by the lobe's tails.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time

import numpy as np

from . import cases as cases_mod
from .. import harness as common
from ..harness.checks import TOLERANCES, Check, tolerance
from ..harness.compare import aggregate as _aggregate
from ..harness.compare import rel_error_map  # noqa: F401  (re-exported)
from ..scenes import furnace, gonio

EXACT_TOL = tolerance("exact_mode")
# The fitted mixtures' bound holds for views and lights up to this angle (the
# fitter's domain, fitting/mixtures.py FIT_VIEW); beyond it they are measured.
FIT_DOMAIN_DEG = 70.0
ORACLE_GGX_TOL = tolerance("oracle_ggx")
ORACLE_BECKMANN_TOL = tolerance("oracle_beckmann")
FURNACE_SIGMAS = tolerance("furnace_sigmas")


# --------------------------------------------------------------------------
# Blender helpers

@contextlib.contextmanager
def quiet(enabled=True):
    """Silence the process's stdout file descriptor (Blender prints a line
    per render) while rendering; stderr stays."""
    if not enabled:
        yield
        return
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def blender_version():
    bpy = common.import_bpy()
    return tuple(bpy.app.version[:2])


def new_material(name):
    """An empty node material holding only a Material Output node."""
    return common.empty_material(name)[0]


def _input(node, *names):
    for name in names:
        if name in node.inputs:
            return node.inputs[name]
    raise KeyError(f"node {node.name!r} has none of the inputs {names}")


def set_sun(node, light_dir, strength=1.0):
    """Point an exact-mode node's light inputs at a sun along ``light_dir``
    (toward the light) of irradiance ``strength``, shadows on."""
    _input(node, "Light Direction", "light_direction").default_value = tuple(
        float(x) for x in light_dir)
    _input(node, "Light Strength", "light_strength").default_value = float(strength)
    for names, value in ((("Point Light", "point_light"), 0.0),
                         (("Shadows", "shadows"), 1.0)):
        try:
            _input(node, *names).default_value = value
        except KeyError:
            pass
    try:
        sock = _input(node, "Light Color", "light_color")
        sock.default_value = (1.0, 1.0, 1.0, 1.0)[:len(sock.default_value)]
    except KeyError:
        pass


def dispose(scene_holder):
    """Remove a built scene with its objects and data (keeps the material)."""
    bpy = common.import_bpy()
    scene = scene_holder.scene
    if scene is None:
        return
    if scene.render.use_persistent_data:
        # Switching it off frees the render's persistent data (Blender's RNA
        # update), which otherwise outlives the scene: Blender 4.5 crashed in
        # the next material created after such a scene was removed.
        scene.render.use_persistent_data = False
    objs = list(scene.collection.all_objects)
    datas = [o.data for o in objs]
    for o in objs:
        bpy.data.objects.remove(o, do_unlink=True)
    for d in datas:
        for kind, coll in ((bpy.types.Mesh, bpy.data.meshes), (bpy.types.Light, bpy.data.lights),
                           (bpy.types.Camera, bpy.data.cameras), (bpy.types.Curve, bpy.data.curves)):
            if isinstance(d, kind):
                coll.remove(d)
                break
    bpy.data.scenes.remove(scene)
    scene_holder.scene = None


def remove_material(mat):
    bpy = common.import_bpy()
    bpy.data.materials.remove(mat)


# --------------------------------------------------------------------------
# comparison helpers

def _verdict(err, tol):
    if tol is None:
        return None
    return bool(err <= tol)


def case_lights(case, light_dirs=None, theta_d=None):
    """The light directions of ``case``: the half-angle sweep for Fresnel
    cases, else ``light_dirs`` (default cases.LIGHT_DIRS)."""
    if case.fresnel_sweep:
        sweep = cases_mod.THETA_D_SWEEP if theta_d is None else theta_d
        return [tuple(gonio.light_for_half_angle(t, 20.0)) for t in sweep]
    dirs = cases_mod.LIGHT_DIRS if light_dirs is None else light_dirs
    return [tuple(gonio.normalize(d)) for d in dirs]


def _render_and_compare(g, expected, keep_images, screen_space_shadows=False, model_peak=0.0):
    """``screen_space_shadows`` (EEVEE's exact mode): pixels the render
    leaves black where the reference is lit beyond EEVEE's tolerance (the
    gonio has no occluder: a screen-space shadow ray that passed behind a
    visible surface; values below it are half-float underflow, compared as
    usual) are counted as ``false_shadow`` and left out of the comparison."""
    with quiet():
        img = g.render()
    mask = g.mask
    false_shadow = 0
    if screen_space_shadows:
        lit = expected.max(axis=-1) > tolerance("eevee_exact") * float(expected[g.mask].max())
        black = g.mask & np.all(img == 0.0, axis=-1) & lit
        false_shadow = int(black.sum())
        mask = g.mask & ~black
    white = g.white_peak()   # the scale where the expectation is black everywhere
    stats = gonio.compare(img, expected, mask, scale=white)
    # the fitted mixtures' domain: views and lights up to 70 deg from the normal
    cos_fit = math.cos(math.radians(FIT_DOMAIN_DEG))
    in_fit = mask & (g.cos_i >= cos_fit) & (g.cos_o >= cos_fit)
    fit_stats = gonio.compare(img, expected, in_fit, scale=white) if in_fit.any() else None
    # over the model's peak (its mirror-direction value, ``model_peak``) where
    # the image holds less: a narrow lobe's highlight may fall between pixels
    fit_peak = (max(fit_stats["peak"], model_peak) or white) if fit_stats else 0.0
    entry = {"light_dir": [float(x) for x in g.light_dir],
             "max_abs_over_peak_fit_domain": (
                 fit_stats["max_abs_error"] / fit_peak if fit_peak > 0 else 0.0),
             "finite": bool(np.isfinite(img).all()),
             # light where the model has some (a black model renders black)
             "lit": bool(np.any(img[g.mask] > 0) or not np.any(expected[g.mask] > 0)),
             "max_rel_error": stats["max_rel_error"], "rms_rel_error": stats["rms_rel_error"],
             "n_pixels": stats["n_pixels"], "worst": stats["worst"],
             "max_abs_over_peak": stats["max_abs_error"] / stats["scale"],
             "render_seconds": g.last_render_seconds, "false_shadow": false_shadow,
             "lit_pixels": int(np.sum(g.mask & np.any(expected > 0.0, axis=-1)))}
    if keep_images:
        entry.update(rendered=img, expected=expected, mask=g.mask,
                     rel_error=rel_error_map(img, expected, g.mask, stats["floor"]))
    return entry


# --------------------------------------------------------------------------
# the checks

BACKENDS = ("osl", "svm", "eevee")


def use_backend(scene, backend, api, mode=None):
    """Set ``scene`` up so that an 'auto' node renders with ``backend``:
    ``"osl"`` (Cycles on the CPU, OSL on), ``"svm"`` (Cycles, OSL off: the
    kernel code of the GPU devices) or ``"eevee"``.  ``mode`` "exact" (the
    scene's materials in exact mode alone): EEVEE without its shadow maps,
    which exact mode does not read (it emits the model, no lamp lights it,
    its shadow is the Raycast node's own ray; the same bit for bit,
    ``tests/test_native.py``) and which take 1.1 s of a 48 x 48 render on
    this machine's software OpenGL."""
    if backend == "osl":
        api.enable_osl(scene)
    elif backend == "svm":
        scene.render.engine = 'CYCLES'
        scene.cycles.device = 'CPU'
        scene.cycles.shading_system = False
    elif backend == "eevee":
        common.configure_eevee(scene, samples=1)
        if mode == "exact":
            scene.eevee.use_shadows = False
    else:
        raise ValueError(f"backend must be one of {BACKENDS}, not {backend!r}")


def run_case(case, mode, *, resolution=96, light_dirs=None, api, theta_d=None,
             keep_images=True, name=None, backend="osl", group_backend="auto"):
    """Render ``case`` (a :class:`.cases.Case`) in ``mode``
    (``"exact"`` or ``"path_traced"``) on the gonio scene for each light
    direction, with the material's node on backend 'auto' and the scene set
    up for ``backend`` (:func:`use_backend`), compare with
    ``gonio.reference`` (addon.reference on the scene's known geometry) and
    return the result dict.  ``group_backend``: the node's own backend
    setting ('auto' unless a test forces one)."""
    if mode not in ("exact", "path_traced"):
        raise ValueError(f"mode must be 'exact' or 'path_traced', not {mode!r}")
    t0 = time.perf_counter()
    version = blender_version()
    mat = new_material(name or f"rm_{case.id}_{mode}")
    node = api.add_model(mat, case.model, mode=mode, backend=group_backend, **case.params)
    per_light = []
    try:
        for ld in case_lights(case, light_dirs, theta_d):
            if mode == "exact":
                set_sun(node, ld, 1.0)
            g = gonio.build_gonio_scene(mat, light_dir=ld, resolution=resolution,
                                        name=f"gonio_{mode}")
            try:
                use_backend(g.scene, backend, api, mode)
                expected = g.reference(case.model, **case.params)
                peak = g.mirror_peak(case.model, FIT_DOMAIN_DEG, **case.params) \
                    if mode == "path_traced" else 0.0
                per_light.append(_render_and_compare(
                    g, expected, keep_images,
                    screen_space_shadows=backend == "eevee" and mode == "exact",
                    model_peak=peak))
            finally:
                dispose(g)
    finally:
        remove_material(mat)
    mx, rms, n = _aggregate(per_light)
    peak_rel = max(p["max_abs_over_peak"] for p in per_light)
    metric = "max_rel_error"
    if mode == "exact":
        status, tol, reason = "exact", EXACT_TOL, "exact_mode"
        if backend == "eevee":
            metric, tol, reason = "max_abs_over_peak", tolerance("eevee_exact"), "eevee_exact"
    else:
        status = case.path_traced_status(version, "osl" if backend == "osl" else "native")
        tol = cases_mod.PATH_TRACED_TOLERANCE[status]
        reason = {"exact": "path_traced_exact", "near": "path_traced_near",
                  "fitted": "path_traced_fitted"}.get(status, "")
        if status == "fitted":  # the bound's domain: views and lights to 70 deg
            metric = "max_abs_over_peak_fit_domain"
        if status == "approx":  # the figure the API and the sidebar state, where there is one
            figure, _where = case.path_traced_error(version,
                                                    "osl" if backend == "osl" else "native")
            if figure is not None:
                tol, reason, metric = figure, "path_traced_measured", \
                    "max_abs_over_peak_fit_domain"
        if backend == "eevee":  # EEVEE's closures are its own: lit and finite is the claim
            tol, reason = None, ""
    fit_domain = max(p["max_abs_over_peak_fit_domain"] for p in per_light)
    measured = {"max_rel_error": mx, "max_abs_over_peak": peak_rel,
                "max_abs_over_peak_fit_domain": fit_domain}[metric]
    false_shadow = sum(p["false_shadow"] for p in per_light)
    false_shadow_fraction = false_shadow / max(sum(p["lit_pixels"] for p in per_light), 1)
    verdict = _verdict(measured, tol)
    if backend == "eevee" and mode == "exact" and \
            false_shadow_fraction > tolerance("eevee_false_shadow"):
        verdict = False
    return _as_check({
        "id": case.id, "model": case.model, "variant": case.variant, "mode": mode,
        "backend": backend, "status": status, "max_rel_error": mx, "rms_rel_error": rms,
        "tolerance": tol, "metric": metric,
        "pass": verdict, "max_abs_over_peak": peak_rel, "n_pixels": n,
        "max_abs_over_peak_fit_domain": fit_domain,
        "false_shadow_pixels": false_shadow, "false_shadow_fraction": false_shadow_fraction,
        "finite": all(p.get("finite", True) for p in per_light),
        "lit": all(p.get("lit", True) for p in per_light),
        "resolution": resolution,
        "params": _jsonable(case.params), "blender": ".".join(map(str, version)),
    }, per_light, reason, time.perf_counter() - t0)


def native_glossy_material(name, distribution, roughness):
    """A material with Blender's own Glossy BSDF (``distribution`` 'GGX' or
    'BECKMANN', white, ``roughness``: Cycles uses alpha = roughness^2)."""
    mat = new_material(name)
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    node = tree.nodes.new("ShaderNodeBsdfGlossy")
    node.distribution = distribution
    node.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    node.inputs["Roughness"].default_value = float(roughness)
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


def run_oracle(distribution, alpha, *, resolution=96, light_dirs=None, api, keep_images=True):
    """The independent oracle: the exact-mode microfacet (``distribution``
    ``"trowbridge_reitz"`` or ``"beckmann"``, ``smith_correlated``, no
    Fresnel, isotropic ``alpha``) against Blender's native Glossy BSDF
    (GGX or Beckmann) with roughness ``sqrt(alpha)`` (Cycles squares it), on
    the same scene.  The render of the native node is the expectation."""
    native = {"trowbridge_reitz": "GGX", "beckmann": "BECKMANN"}[distribution]
    tol = ORACLE_GGX_TOL if distribution == "trowbridge_reitz" else ORACLE_BECKMANN_TOL
    params = {"distribution": distribution, "shadowing": "smith_correlated", "alpha": alpha}
    t0 = time.perf_counter()
    ours = new_material(f"oracle_ours_{distribution}")
    node = api.add_model(ours, "microfacet", mode="exact", **params)
    theirs = native_glossy_material(f"oracle_native_{distribution}", native, math.sqrt(alpha))
    per_light, vs_ref = [], []
    try:
        for ld in [tuple(gonio.normalize(d)) for d in (light_dirs or cases_mod.LIGHT_DIRS)]:
            set_sun(node, ld, 1.0)
            g_native = gonio.build_gonio_scene(theirs, light_dir=ld, resolution=resolution,
                                               name="oracle_native")
            try:
                with quiet():
                    native_img = g_native.render()
                ref = g_native.reference("microfacet", **params)
                vs_ref.append(gonio.compare(native_img, ref, g_native.mask)["max_rel_error"])
            finally:
                dispose(g_native)
            g = gonio.build_gonio_scene(ours, light_dir=ld, resolution=resolution,
                                        name="oracle_ours")
            try:
                api.enable_osl(g.scene)
                per_light.append(_render_and_compare(g, native_img, keep_images))
            finally:
                dispose(g)
    finally:
        remove_material(ours)
        remove_material(theirs)
    mx, rms, n = _aggregate(per_light)
    return _as_check({
        "id": f"oracle[{distribution}]", "model": "microfacet",
        "variant": f"{distribution}/smith_correlated alpha={alpha:g} vs native Glossy {native} "
                   f"r={math.sqrt(alpha):.4g}",
        "mode": "oracle", "status": "exact" if native == "GGX" else "near",
        "max_rel_error": mx, "rms_rel_error": rms, "tolerance": tol, "pass": _verdict(mx, tol),
        "max_abs_over_peak": max(p["max_abs_over_peak"] for p in per_light),
        "native_vs_reference_max_rel_error": max(vs_ref), "n_pixels": n,
        "resolution": resolution, "params": params, "blender": ".".join(map(str, blender_version())),
    }, per_light, "oracle_ggx" if native == "GGX" else "oracle_beckmann", time.perf_counter() - t0)


# Energy-normalised models whose path-traced output must reflect <= 1 in the
# furnace: (model, params, variant).
FURNACE_CASES = (
    ("phong", {"normalization": "energy", "exponent": 2.0}, "energy s=2"),
    ("phong", {"normalization": "energy", "exponent": 50.0}, "energy s=50"),
    ("microfacet", {"distribution": "trowbridge_reitz", "shadowing": "smith_correlated",
                    "alpha": 0.6}, "trowbridge_reitz/smith_correlated F=1 alpha=0.6"),
    ("microfacet", {"distribution": "beckmann", "shadowing": "smith_correlated",
                    "alpha": 0.6}, "beckmann/smith_correlated F=1 alpha=0.6"),
    ("microfacet", {"distribution": "gaussian", "shadowing": "vgroove",
                    "beta": 30.0 * math.pi / 180.0}, "gaussian/vgroove F=1 beta=30deg"),
)


def run_furnace(model, params, variant, *, resolution=64, samples=64, api, bins=8,
                keep_images=True):
    """White furnace of the path-traced output: the albedo per view-angle bin
    must stay <= 1 + FURNACE_SIGMAS standard errors of the bin's mean."""
    t0 = time.perf_counter()
    mat = new_material(f"furnace_{model}")
    api.add_model(mat, model, mode="path_traced", **params)
    f = furnace.build_furnace_scene(mat, resolution=resolution, samples=samples)
    try:
        api.enable_osl(f.scene)
        with quiet():
            img = f.render()
    finally:
        dispose(f)
        remove_material(mat)
    cos_c, albedo, counts = f.albedo_by_angle(img, bins)
    grey = img[..., :3].max(axis=-1)
    edges = np.linspace(0.0, 1.0, bins + 1)
    idx = np.clip(np.digitize(f.cos_o[f.mask], edges) - 1, 0, bins - 1)
    vals = grey[f.mask] / f.environment
    margins = np.full(bins, np.nan)
    excess = -np.inf
    for b in range(bins):
        if counts[b] > 1:
            v = vals[idx == b]
            margins[b] = FURNACE_SIGMAS * v.std(ddof=1) / math.sqrt(len(v))
            excess = max(excess, float(v.mean() - 1.0 - margins[b]))
    max_albedo = float(np.nanmax(albedo))
    return _as_check({
        "id": f"furnace[{model}/{variant}]", "model": model, "variant": variant,
        "mode": "furnace", "status": "bound", "max_albedo": max_albedo,
        "mean_albedo": [float(x) for x in f.mean(img)],
        "albedo_by_angle": [[float(c), *[float(x) for x in a]] for c, a in zip(cos_c, albedo)],
        "margin": float(np.nanmax(margins)),
        "max_rel_error": None, "rms_rel_error": None,
        "tolerance": float(1.0 + np.nanmax(margins)), "pass": bool(excess <= 0.0),
        "samples": samples, "resolution": resolution, "params": _jsonable(params),
    }, [{"rendered": img, "mask": f.mask}] if keep_images else [], "furnace_sigmas",
        time.perf_counter() - t0)


# --------------------------------------------------------------------------

def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def _as_check(values, per_light, tolerance_name, seconds):
    """The record of a gonio, oracle or furnace run: its numbers in
    ``values`` and the per-light arrays in ``images["lights"]``."""
    values = dict(values)
    passed = values.pop("pass")
    if values["mode"] == "furnace":
        measured = f"max albedo {values['max_albedo']:.4f}"
        expected = f"<= {values['tolerance']:.4f} (1 + MC margin)"
    else:
        measured = (f"max rel error {values['max_rel_error']:.2e}, rms "
                    f"{values['rms_rel_error']:.2e}, max |diff|/peak "
                    f"{values['max_abs_over_peak']:.2e}")
        if values.get("metric") == "max_abs_over_peak_fit_domain":
            measured += (f" ({values['max_abs_over_peak_fit_domain']:.2e} with view and light "
                         f"<= {FIT_DOMAIN_DEG:g} deg)")
        tol = values["tolerance"]
        what = {"max_rel_error": "rel error", "max_abs_over_peak": "|diff|/peak",
                "max_abs_over_peak_fit_domain": f"|diff|/peak (view and light <= "
                                                f"{FIT_DOMAIN_DEG:g} deg)"}.get(
            values.get("metric"), "rel error")
        expected = f"{what} <= {tol:.3g}" if tol is not None else \
            "measured (no closure is the model)"
    values["lights"] = [{k: _jsonable(v) for k, v in p.items() if not isinstance(v, np.ndarray)}
                        for p in per_light if "light_dir" in p]
    backend = values.get("backend")
    name = f"{values['id']} {values['mode']}" + (f" {backend}" if backend not in (None, "osl") else "")
    return Check(name=name, passed=passed, measured=measured,
                 expected=expected, group=values["mode"],
                 tolerance=TOLERANCES[tolerance_name].reason if tolerance_name else "",
                 values=values, images={"lights": per_light}, seconds=seconds)
