# SPDX-License-Identifier: GPL-3.0-or-later
"""Anisotropic reflection and hair, rendered and judged (slides "Reflection
from a Cylinder", "Shape of Anisotropic Highlights", "Kay-Kajiya Model",
"Hair Model").

The scenes and their known geometry are :mod:`verification.scenes.anisotropy`;
here each scene is rendered through the public API, compared with
``addon.reference`` on that geometry, and its highlight measured
(``*_run``); :func:`checks` turns the measurements into
:class:`~verification.harness.checks.Check` records, with the renders as
images for the report (:mod:`report.anisotropy`).
"""

from __future__ import annotations

import math

import numpy as np

from .. import harness as common
from ..harness.checks import TOLERANCES, Check, tolerance
from ..scenes.anisotropy import (  # noqa: F401
    BRUSHED_TR,
    BRUSHED_WARD,
    CYLINDER_MODELS,
    CYLINDER_SUNS,
    Cylinder,
    DISC_LIGHT,
    DISC_LIGHT_INTENSITY,
    HAIR_DEMO_SUN,
    HAIR_SUN,
    HAIR_VIEW,
    KK,
    KK_BLACK,
    KK_BROWN,
    RING_RADIUS,
    RING_SUN,
    RING_TUBE,
    RING_VIEW,
    VIA,
    curve_tangent_node,
    disc_mesh,
    hair_band_expected_y,
    hair_curves,
    hair_fan,
    hair_lock,
    link_object,
    make_material,
    new_material,
    new_scene,
    pixel_offsets,
    pixel_rays,
    radial_normal_from_position,
    radial_tangent_node,
    reference_shade,
    render_scene,
    ring_tangent_from_position,
    segment_mask,
    torus_hit,
    torus_mesh,
)


def cylinder_run(model_key, sun_key, *, mode="exact", resolution=(96, 48), path=None, via=None):
    """Render one model on the cylinder under one sun and compare with the
    reference.  Returns a dict of numbers (``compare`` keys, highlight data,
    render seconds) and the images."""
    model, params = CYLINDER_MODELS[model_key]
    sun = common.normalize(CYLINDER_SUNS[sun_key])
    cyl = Cylinder(resolution=resolution)
    light = {"light_direction": sun, "shadows": 0.0, "point_light": 0.0}
    mat, _ = make_material(f"cyl_{model_key}_{sun_key}_{mode}", model, params,
                           output="Direct" if mode == "exact" else "BSDF", light=light,
                           tangent=(1.0, 0.0, 0.0), normal=radial_normal_from_position, via=via)
    scene = cyl.build(mat, name=f"cyl_{model_key}_{sun_key}_{mode}",
                      sun_dir=sun if mode != "exact" else None)
    img, seconds = render_scene(scene, path)
    exp = cyl.expected(model, params, sun)
    exp = cyl.expected(model, params, sun, pixel_offsets(resolution))
    res = common.compare(img, exp, cyl.mask)
    res["max_rel_error_at_centres"] = common.compare(
        img, cyl.expected(model, params, sun), cyl.mask)["max_rel_error"]
    diff = (img - exp)[cyl.mask] / max(res["peak"], 1e-30)
    res["rms_abs_over_peak"] = float(np.sqrt(np.mean(diff ** 2)))
    res["max_abs_over_peak"] = float(np.max(np.abs(diff)))
    res["render_seconds"] = seconds
    # highlight across the cylinder (surface models): the normal at the
    # brightest pixel against the direction of H with its axial part removed
    lum = img.mean(-1) * cyl.mask
    j, i = np.unravel_index(int(np.argmax(lum)), lum.shape)
    H = common.normalize(sun + cyl.wo)
    Hp = common.normalize(H - np.dot(H, cyl.tangent) * cyl.tangent)
    res["T_dot_H"] = float(np.dot(H, cyl.tangent))
    res["highlight_normal_angle_deg"] = float(np.degrees(np.arccos(np.clip(
        np.dot(cyl.normal[j, i], Hp), -1.0, 1.0))))
    res["pixel_angle_deg"] = float(np.degrees(cyl.ortho_scale / resolution[0] / cyl.radius))
    return res, img, exp, cyl




def ring_run(*, resolution=(96, 80), path=None):
    """Kajiya-Kay on the fibre ring: the highlight against the mirror cone.

    Renders the Specular output and the shader's cos_theta_l / cos_theta_e
    (packed 0.5 + 0.5 x) in two renders.  Returns numbers and the images."""
    view = common.normalize(RING_VIEW)
    sun = common.normalize(RING_SUN)
    ortho = 1.7
    scene, basis = new_scene("aniso_ring", view_dir=view, ortho_scale=ortho, resolution=resolution)
    light = {"light_direction": sun, "shadows": 0.0}
    mat_s, _ = make_material("ring_spec", "kajiya_kay", KK, output="Specular", light=light,
                             tangent=ring_tangent_from_position)
    mesh = torus_mesh("aniso_ring_torus", RING_RADIUS, RING_TUBE)
    obj = link_object(scene, "aniso_ring_torus", mesh, mat_s)
    spec, s1 = render_scene(scene)
    mat_c, _ = make_material("ring_cos", "kajiya_kay", KK, output="pack:cos_theta_l,cos_theta_e",
                             light=light, tangent=ring_tangent_from_position)
    obj.material_slots[0].material = mat_c
    packed, s2 = render_scene(scene)
    mat_d, _ = make_material("ring_direct", "kajiya_kay", KK, output="Direct", light=light,
                             tangent=ring_tangent_from_position)
    obj.material_slots[0].material = mat_d
    direct, s3 = render_scene(scene, path)

    origin, d = pixel_rays(basis, resolution, ortho)
    hit, P = torus_hit(origin, d, RING_RADIUS, RING_TUBE)
    core = hit.copy()
    for dx in (-1.0, 1.0):
        for dy in (-1.0, 1.0):
            o2, _ = pixel_rays(basis, resolution, ortho, (dx, dy))
            core &= torus_hit(o2, d, RING_RADIUS, RING_TUBE)[0]
    T = np.zeros(P.shape)
    T[..., 0], T[..., 1] = -P[..., 1], P[..., 0]
    T = T / np.maximum(np.linalg.norm(T, axis=-1, keepdims=True), 1e-30)
    H = common.normalize(sun + view)
    s = spec[..., 0] * core
    j, i = np.unravel_index(int(np.argmax(s)), s.shape)
    cl = 2.0 * packed[..., 0] - 1.0
    ce = 2.0 * packed[..., 1] - 1.0
    lh = float(np.linalg.norm(sun + view))
    th_render = float((cl[j, i] + ce[j, i]) / lh)
    th_geom = float(np.dot(T[j, i], H))
    # cosines output by the shader vs the analytic torus (faceted mesh: ~1e-2)
    cos_err = max(float(np.max(np.abs(cl[core] - T[core] @ sun))),
                  float(np.max(np.abs(ce[core] - T[core] @ view))))
    # where the cone crosses the ring: T(phi).H = 0 at phi* = atan2(Hy, Hx) (mod pi)
    th = T @ H
    both_h = core[:, 1:] & core[:, :-1]
    both_v = core[1:, :] & core[:-1, :]
    th_step = max(float(np.max(np.abs(np.diff(th, axis=1))[both_h])),
                  float(np.max(np.abs(np.diff(th, axis=0))[both_v])))
    phi_star = math.atan2(H[1], H[0])
    phi = math.atan2(P[j, i, 1], P[j, i, 0])
    dphi = (phi - phi_star + math.pi / 2.0) % math.pi - math.pi / 2.0
    exp = np.zeros(direct.shape)
    exp[core] = _kk(sun, view, T[core], KK)
    return {
        "T_dot_H_render": th_render,
        "T_dot_H_geometry": th_geom,
        "T_dot_H_step_per_pixel": th_step,
        "T_dot_E": float(np.dot(T[j, i], view)),
        "T_dot_L": float(np.dot(T[j, i], sun)),
        "highlight_azimuth_error_deg": float(np.degrees(abs(dphi))),
        "pixel_azimuth_step_deg": float(np.degrees(ortho / resolution[0] / RING_RADIUS)),
        "cos_outputs_vs_geometry_max": cos_err,
        "peak_specular": float(s[j, i]),
        "ks": KK["ks"][0],
        "render_seconds": s1 + s2 + s3,
        "n_pixels": int(core.sum()),
    }, direct, exp, core


def _kk(wi, wo, T, params):
    from addon import reference
    return reference.shade("kajiya_kay", wi, wo, tangent=T, **params)




def principal_axis(img, x, y, threshold=0.1):
    """Intensity-weighted second moments of the pixels brighter than
    ``threshold`` x peak: (angle of the major axis in degrees in [0, 180),
    ratio of the standard deviations major/minor, centroid)."""
    w = np.where(img >= threshold * img.max(), img, 0.0)
    s = w.sum()
    cx, cy = (w * x).sum() / s, (w * y).sum() / s
    dx, dy = x - cx, y - cy
    cov = np.array([[(w * dx * dx).sum(), (w * dx * dy).sum()],
                    [(w * dx * dy).sum(), (w * dy * dy).sum()]]) / s
    vals, vecs = np.linalg.eigh(cov)
    major = vecs[:, 1]
    angle = math.degrees(math.atan2(major[1], major[0])) % 180.0
    return angle, math.sqrt(vals[1] / max(vals[0], 1e-30)), (cx, cy)




def disc_run(model="ward", *, resolution=96, tangent_rotation=0.0, path=None):
    """The brushed disc under a point light (exact mode).  Returns numbers
    (comparison with the reference, streak orientation) and the images."""
    params = BRUSHED_WARD if model == "ward" else BRUSHED_TR
    osl_model = "ward" if model == "ward" else "microfacet"
    res = (resolution, resolution)
    ortho = 2.2
    view = np.array([0.0, 0.0, 1.0])
    scene, basis = new_scene(f"aniso_disc_{model}", view_dir=view, ortho_scale=ortho, resolution=res)
    light = {"point_light": 1.0, "light_position": DISC_LIGHT,
             "light_strength": DISC_LIGHT_INTENSITY, "shadows": 0.0}
    mat, _ = make_material(f"disc_{model}", osl_model, params, output="Direct", light=light,
                           tangent=radial_tangent_node,
                           extra={"tangent_rotation": tangent_rotation})
    link_object(scene, "aniso_disc", disc_mesh("aniso_disc"), mat)
    img, seconds = render_scene(scene, path)

    p = ortho / resolution

    def geometry(offset):
        origin, _ = pixel_rays(basis, res, ortho, offset)
        X, Y = origin[..., 0], origin[..., 1]  # straight down: the hit is (X, Y, 0)
        rho = np.hypot(X, Y)
        P = np.stack([X, Y, np.zeros_like(X)], axis=-1)
        T = np.stack([-Y, X, np.zeros_like(X)], axis=-1) / np.maximum(rho, 1e-30)[..., None]
        T = math.cos(tangent_rotation) * T + math.sin(tangent_rotation) * np.cross((0.0, 0.0, 1.0), T)
        return X, Y, rho, P, T

    def expected(offset):
        _, _, _, P, T = geometry(offset)
        Lv = np.asarray(DISC_LIGHT) - P
        d2 = np.sum(Lv * Lv, axis=-1)
        wi = Lv / np.sqrt(d2)[..., None]
        out = np.zeros(img.shape)
        out[mask] = reference_shade(osl_model, wi[mask], view, (0.0, 0.0, 1.0), T[mask],
                                    params) * (DISC_LIGHT_INTENSITY / d2[mask])[:, None]
        return out

    X, Y, rho, _, _ = geometry((0.0, 0.0))
    # the tangent field turns fast near the centre (singular at it): keep 3 px away
    mask = (rho < math.cos(math.pi / 128) - 1.5 * p) & (rho > 3.0 * p)
    exp = expected(pixel_offsets(res))
    cmp = common.compare(img, exp, mask)
    cmp["max_rel_error_at_centres"] = common.compare(img, expected((0.0, 0.0)), mask)["max_rel_error"]
    lum = img.mean(-1) * mask
    angle, elong, centroid = principal_axis(lum, X, Y)
    expected_angle = math.degrees(math.atan2(DISC_LIGHT[1], DISC_LIGHT[0])) % 180.0
    err = (angle - expected_angle + 90.0) % 180.0 - 90.0
    cmp.update(streak_angle_deg=angle, expected_angle_deg=expected_angle,
               streak_angle_error_deg=abs(err), elongation=elong,
               render_seconds=seconds)
    # the same on the reference image (how well the moment fit itself does)
    a_ref, _, _ = principal_axis(exp.mean(-1), X, Y)
    cmp["reference_streak_angle_error_deg"] = abs((a_ref - expected_angle + 90.0) % 180.0 - 90.0)
    return cmp, img, exp, mask


class _HairFan:
    """The fan of straight strands (:func:`hair_fan`) seen along
    ``HAIR_VIEW`` under the sun ``HAIR_SUN``: a new scene ``name`` with the
    curves (thick, unlinked), and Kajiya-Kay's expected Direct per strand."""

    ORTHO = 2.4
    RADIUS = 0.04

    def __init__(self, name, resolution):
        self.view = common.normalize(HAIR_VIEW)
        self.sun = common.normalize(HAIR_SUN)
        self.resolution = resolution
        self.scene, self.basis = new_scene(name, view_dir=self.view, ortho_scale=self.ORTHO,
                                           resolution=resolution)
        self.scene.cycles_curves.shape = 'THICK'
        self.dirs, self.strands = hair_fan()
        self.curves = hair_curves(name + "_fan", self.strands, self.RADIUS)

    def expected(self, strength):
        """``(index, mask, expected)``: the strand each pixel sees (-1:
        none), the pixels on a strand, and Kajiya-Kay (``KK``) there with
        the strand's direction, times ``strength``."""
        idx = segment_mask(self.basis, self.resolution, self.ORTHO, self.strands, self.RADIUS)
        mask = idx >= 0
        exp = np.zeros(mask.shape + (3,))
        exp[mask] = _kk(self.sun, self.view, self.dirs[idx[mask]], KK) * strength
        return idx, mask, exp


def hair_run(*, resolution=(96, 96), strength=2.0, path=None, via=None):
    """Kajiya-Kay exact on a fan of straight hair strands: Direct vs the
    reference per strand, Diffuse + Specular = Color / strength, the
    curve tangent the Geometry node gives, and the highlight's |T.H|."""
    fan = _HairFan("aniso_hair", resolution)
    view, sun, scene, hc = fan.view, fan.sun, fan.scene, fan.curves
    # Through the api the Light inputs follow a sun lamp (bind_light); the
    # lamp itself lights nothing here (the outputs are emissions).
    lamp = common.add_sun(scene, sun, strength)
    lamp.data.use_shadow = False  # the reference has no shadows; bound Shadows follow it
    if (via or VIA) == "api":
        light = {"shadows": 0.0}
    else:
        light = {"light_direction": sun, "shadows": 0.0, "light_strength": strength}
    mats, node = {}, None
    for out in ("Direct", "Diffuse", "Specular", "Color"):
        mats[out], node = make_material(f"hair_{out}", "kajiya_kay", KK, output=out,
                                        light=light, tangent=curve_tangent_node, via=via)
        if (via or VIA) == "api":
            from addon import api
            api.bind_light(node, lamp)
    output_names = [o.name for o in node.outputs]
    obj = link_object(scene, "aniso_hair_fan", hc, mats["Direct"])
    imgs, seconds = {}, 0.0
    for out in ("Direct", "Diffuse", "Specular", "Color"):
        obj.material_slots[0].material = mats[out]
        imgs[out], s = render_scene(scene, path if out == "Direct" else None)
        seconds += s
    # the tangent the Geometry node gives on curves (packed 0.5 + 0.5 t)
    tmat = new_material("hair_tangent_probe")
    tree = tmat.node_tree
    mo = tree.nodes.new("ShaderNodeOutputMaterial")
    em = tree.nodes.new("ShaderNodeEmission")
    ma = tree.nodes.new("ShaderNodeVectorMath")
    ma.operation = 'MULTIPLY_ADD'
    ma.inputs[1].default_value = (0.5, 0.5, 0.5)
    ma.inputs[2].default_value = (0.5, 0.5, 0.5)
    tree.links.new(curve_tangent_node(tree), ma.inputs[0])
    tree.links.new(ma.outputs[0], em.inputs["Color"])
    tree.links.new(em.outputs[0], mo.inputs["Surface"])
    tmat.cycles.emission_sampling = 'NONE'
    obj.material_slots[0].material = tmat
    tang, s = render_scene(scene)
    seconds += s
    # the Tangent node (UV map) on the same curves, for the record
    uv = tree.nodes.new("ShaderNodeTangent")
    uv.direction_type = 'UV_MAP'
    tree.links.new(uv.outputs["Tangent"], em.inputs["Color"])
    uv_img, s = render_scene(scene)
    seconds += s

    idx, mask, exp = fan.expected(strength)
    dirs = fan.dirs
    T = np.zeros(mask.shape + (3,))
    T[mask] = dirs[idx[mask]]
    cmp = common.compare(imgs["Direct"], exp, mask)
    ds = imgs["Diffuse"] + imgs["Specular"]
    sum_err = float(np.max(np.abs(ds[mask] - imgs["Color"][mask] / strength))
                    / max(np.max(np.abs(imgs["Color"][mask] / strength)), 1e-30))
    tv = 2.0 * tang - 1.0
    # |cos| between the node's tangent and the strand direction (sign is free)
    cos_t = np.abs(np.sum(tv[mask] * T[mask], axis=-1)) / np.maximum(
        np.linalg.norm(tv[mask], axis=-1), 1e-30)
    # highlight: the strand with the largest specular, against the cone
    spec = imgs["Specular"][..., 0]
    k_best = int(idx.flat[int(np.argmax(np.where(mask, spec, -1.0)))])
    H = common.normalize(sun + view)
    th = np.abs(dirs @ H)
    cmp.update(
        diffuse_plus_specular_vs_color=sum_err,
        tangent_node_uv_on_curves_max=float(np.max(np.abs(uv_img))),
        tangent_max_angle_deg=float(np.degrees(np.arccos(np.clip(cos_t.min(), -1, 1)))),
        highlight_strand=k_best, highlight_T_dot_H=float(th[k_best]),
        min_T_dot_H_over_strands=float(th.min()),
        render_seconds=seconds, n_strands=len(fan.strands), node_outputs=output_names,
    )
    return cmp, imgs, exp, mask


def hair_strand_tangent_run(backend, *, strand=True, resolution=(96, 96), strength=2.0):
    """Kajiya-Kay exact through the api on the fan of straight strands,
    rendered with ``backend`` ("osl", "svm" or "eevee",
    ``verify.use_backend``), against the reference with each strand's known
    direction.  ``strand``: the Tangent input fed by
    ``api.use_strand_tangent``; else left unconnected (the group's default,
    the UV tangent, 0 on curves).  Returns ``(comparison, image, expected,
    mask)``, the comparison (``common.compare``) with ``max_abs_over_peak``."""
    from addon import api

    from . import verify

    name = f"aniso_hair_strand_{backend}_{int(strand)}"
    fan = _HairFan(name, resolution)
    light = {"light_direction": fan.sun, "shadows": 0.0, "light_strength": strength}
    mat, node = make_material(name, "kajiya_kay", KK, light=light, via="api")
    if strand:
        api.use_strand_tangent(node)
    link_object(fan.scene, name, fan.curves, mat)
    verify.use_backend(fan.scene, backend, api)
    img, _seconds = render_scene(fan.scene)
    _idx, mask, exp = fan.expected(strength)
    cmp = common.compare(img, exp, mask)
    cmp.update(max_abs_over_peak=cmp["max_abs_error"] / cmp["peak"])
    return cmp, img, exp, mask


def hair_demo(*, resolution=(120, 120)):
    """Black and brown hair (Kajiya-Kay exact, presets KK_BLACK / KK_BROWN,
    shadows on) on a lock of wavy strands.  Returns ``(images, numbers)``:
    the renders by name and the measured height of the highlight band (the
    row of largest mean brightness over the hair pixels, black hair) against
    :func:`hair_band_expected_y`, and the render time."""
    view = np.array([0.0, 0.0, 1.0])
    sun = common.normalize(HAIR_DEMO_SUN)
    ortho = 2.0
    imgs = {}
    seconds = 0.0
    for name, params in (("black", KK_BLACK), ("brown", KK_BROWN)):
        scene, _ = new_scene(f"aniso_hair_{name}", view_dir=view, ortho_scale=ortho,
                          resolution=resolution)
        scene.cycles_curves.shape = 'THICK'
        mat, _ = make_material(f"hair_{name}", "kajiya_kay", params, output="Direct",
                               light={"light_direction": sun, "shadows": 1.0,
                                      "light_strength": 2.0},
                               tangent=curve_tangent_node)
        link_object(scene, f"aniso_hair_{name}", hair_curves(f"lock_{name}", hair_lock(),
                                                               0.012), mat)
        img, s = render_scene(scene)
        seconds += s
        imgs[name] = img
    img = imgs["black"]
    lum = img.mean(-1)
    hair = lum > 0
    rows = np.where(hair.sum(1) >= 5, (lum * hair).sum(1) / np.maximum(hair.sum(1), 1), 0.0)
    j = int(np.argmax(rows))
    h = resolution[1]
    band_y = (h / 2.0 - j - 0.5) * ortho / resolution[0]
    return imgs, {"band_y": band_y, "band_y_expected": hair_band_expected_y(),
                   "pixel": ortho / resolution[0], "render_seconds": seconds}


# --------------------------------------------------------------------------
# the checks

def _check(name, passed, measured, expected, tol_name="", images=None, **values):
    return Check(name=name, passed=None if passed is None else bool(passed), measured=measured,
                 expected=expected, group="anisotropy",
                 tolerance=TOLERANCES[tol_name].reason if tol_name else "",
                 values=values, images=images or {})


def checks():
    """Render every scene at a small size and judge it: a list of Checks,
    each with its render(s) in ``images`` (arrays: name -> (image, scale);
    scale None = the 99.5th percentile)."""
    out = []
    exact = tolerance("exact_mode")

    # cylinder, exact mode, three models x three suns
    for mk in CYLINDER_MODELS:
        rows, imgs = {}, []
        for sk in CYLINDER_SUNS:
            r, img, _exp, _cyl = cylinder_run(mk, sk)
            rows[sk] = r
            imgs.append(img)
        worst = max(r["max_rel_error"] for r in rows.values())
        stack = {f"cylinder_{mk}": (np.concatenate(imgs, 0), None)}
        out.append(_check(f"{mk} on the cylinder, exact mode vs reference (3 suns)",
                          worst <= exact, f"max rel error {worst:.2e}", f"<= {exact:g}",
                          "exact_mode", stack, max_rel_error=worst, runs=rows))
        if mk != "kajiya_kay":
            ang = max(r["highlight_normal_angle_deg"] for r in rows.values())
            step = rows["sun_a"]["pixel_angle_deg"]
            out.append(_check(f"{mk}: brightest normal on the cylinder vs H minus its axial part",
                              ang <= 2.0 * step, f"{ang:.2f} deg",
                              f"<= 2 pixels of normal angle ({2 * step:.2f} deg)", "", stack,
                              highlight_normal_angle_deg=ang, pixel_angle_deg=step))

    # path-traced mode on the cylinder (BSDF output + a sun lamp): measured
    for mk in CYLINDER_MODELS:
        rows, imgs = {}, []
        for sk in CYLINDER_SUNS:
            r, img, exp, _ = cylinder_run(mk, sk, mode="path_traced")
            rows[sk] = r
            imgs.append(np.concatenate([img, np.zeros((img.shape[0], 2, 3)), exp], 1))
        rms = max(r["rms_abs_over_peak"] for r in rows.values())
        mx = max(r["max_abs_over_peak"] for r in rows.values())
        out.append(_check(f"{mk} path-traced (BSDF, left) vs reference (right), 3 suns",
                          None, f"worst rms {rms:.3g}, worst max {mx:.3g} of the peak",
                          "measured only (no closure is this model)" if mk != "microfacet_tr"
                          else "measured (Cycles' GGX closure is this model)", "",
                          {f"cylinder_{mk}_path_traced": (np.concatenate(imgs, 0), None)},
                          rms_abs_over_peak=rms, max_abs_over_peak=mx))

    # fibre ring: the mirror cone
    r, img, _exp, _core = ring_run()
    step = r["pixel_azimuth_step_deg"]
    out.append(_check("Kajiya-Kay highlight on the mirror cone T.H = 0",
                      abs(r["T_dot_H_render"]) <= r["T_dot_H_step_per_pixel"]
                      and r["highlight_azimuth_error_deg"] <= step,
                      f"|T.H| {abs(r['T_dot_H_render']):.4f} (T.E {r['T_dot_E']:.3f}, "
                      f"T.L {r['T_dot_L']:.3f}); azimuth off by "
                      f"{r['highlight_azimuth_error_deg']:.2f} deg",
                      f"|T.H| <= {r['T_dot_H_step_per_pixel']:.3f} (its change over one pixel), "
                      f"azimuth <= {step:.2f} deg (one pixel)", "",
                      {"ring_kajiya_kay": (img, None)}, **r))

    # brushed disc
    for model in ("ward", "microfacet_tr"):
        r, img, _exp, _mask = disc_run(model)
        images = {f"disc_{model}": (img, None)}
        out.append(_check(f"brushed disc ({model}), tangential brushing: radial streak",
                          r["streak_angle_error_deg"] <= tolerance("streak_angle_deg"),
                          f"axis {r['streak_angle_deg']:.2f} deg (elongation "
                          f"{r['elongation']:.1f})", f"{r['expected_angle_deg']:.2f} deg +- 2",
                          "streak_angle_deg", images, **r))
        out.append(_check(f"brushed disc ({model}), point light, exact vs reference",
                          r["max_rel_error"] <= exact, f"max rel error {r['max_rel_error']:.2e}",
                          f"<= {exact:g}", "exact_mode", images, max_rel_error=r["max_rel_error"]))

    # hair
    r, imgs, _exp, _mask = hair_run()
    images = {"hair_fan": (imgs["Direct"], None)}
    out.append(_check("hair curves, Kajiya-Kay exact vs reference", r["max_rel_error"] <= exact,
                      f"max rel error {r['max_rel_error']:.2e}", f"<= {exact:g}", "exact_mode",
                      images, max_rel_error=r["max_rel_error"]))
    out.append(_check("Diffuse + Specular = Color / light strength",
                      r["diffuse_plus_specular_vs_color"] <= tolerance("terms_sum"),
                      f"{r['diffuse_plus_specular_vs_color']:.2e}", "<= 1e-5 of peak",
                      "terms_sum", images,
                      diffuse_plus_specular_vs_color=r["diffuse_plus_specular_vs_color"]))
    demo, nums = hair_demo()
    err = abs(nums["band_y"] - nums["band_y_expected"])
    for name, img in demo.items():
        out.append(_check(f"{name} hair: Kajiya-Kay highlight band where the strands cross the "
                          "mirror cone", err <= tolerance("hair_band"),
                          f"band at y = {nums['band_y']:.3f}",
                          f"y = {nums['band_y_expected']:.3f} +- 0.05", "hair_band",
                          {f"hair_{name}": (img, 1.0)}, **nums))
    return out
