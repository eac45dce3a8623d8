# SPDX-License-Identifier: GPL-3.0-or-later
"""Anisotropic reflection and hair: scenes with per-pixel known geometry.

Slides: "Reflection from a Cylinder", "Shape of Anisotropic Highlights",
"Kay-Kajiya Model", "Hair Model".  Every scene is lit by one light, seen
through an orthographic camera, and rendered with Cycles (CPU, OSL, 1 sample,
no bounces) into a float32 EXR.  The geometry of every measured pixel (hit
point, normal, tangent, wi, wo) is computed here with numpy, never read from
the render, and the expectation comes from ``addon.reference.shade``.

Scenes
------
- **cylinder**: an open 128-sided tube along world X (radius 0.3, longer than
  the frame), seen from ``view_dir`` tilted 35 degrees along the axis.  The
  shader's normal is the analytic radial normal at the hit point
  (``normalize(0, Py, Pz)`` from the Position node; the same formula is
  applied to the analytically intersected facet in numpy), the tangent the
  constant axis (1, 0, 0).  Kajiya-Kay, Ward and anisotropic Trowbridge-Reitz.
- **fibre ring**: a thin torus (a fibre bent into a circle of radius 0.7 in
  the XY plane) whose tangent ``Z x P`` circles the Z axis, seen from 45
  degrees.  Kajiya-Kay's highlight must sit where the fibre crosses the
  mirror cone ``T.E = -T.L`` (``T.H = 0``).  The shader's own
  ``cos_theta_l`` and ``cos_theta_e`` outputs give ``T.H`` on the rendered
  pixels.
- **brushed disc**: a flat disc (radius 1, normal +Z) brushed tangentially
  (Blender's Tangent node, RADIAL about Z), seen from above, under a POINT
  light (exact mode: ``point_light = 1``).  With ``alpha_x`` (along the
  brushing) much smaller than ``alpha_y``, the highlight is a streak.
  Where it runs: the lobe needs ``H.T ~ 0``.  From straight above,
  ``E = (0, 0, 1)`` adds nothing horizontal to ``H``, so the horizontal part
  of ``H`` points from the pixel ``p`` toward the light's foot ``l``:
  ``H.T(p) = 0`` iff ``(l - p) x p = 0`` iff ``l x p = 0``, i.e. ``p`` lies on
  the line through the centre and ``l``.  Tangential brushing gives a RADIAL
  streak, along ``atan2(ly, lx)``.
- **hair**: a Blender hair Curves object (Cycles 3D curves, shape 'THICK'):
  a fan of straight strands, Kajiya-Kay exact with the tangent from the
  Geometry node's Tangent output (on curves ``normalize(dPdu)``, the curve
  direction; the Tangent node gives 0 on curves), and small demo renders of
  a lock of wavy black and brown hair.

``figures(out_dir)`` renders everything at a small size and returns the
figures and checks for the report.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .. import harness as common

# --------------------------------------------------------------------------
# models and their OSL parameters

KK = dict(kd=(0.25, 0.12, 0.05), ks=(0.5, 0.5, 0.5), exponent=40.0)
KK_BLACK = dict(kd=(0.012, 0.010, 0.009), ks=(0.30, 0.30, 0.30), exponent=60.0)
KK_BROWN = dict(kd=(0.30, 0.14, 0.06), ks=(0.22, 0.20, 0.18), exponent=30.0)
WARD = dict(alpha_x=0.1, alpha_y=0.35, ks=(1.0, 1.0, 1.0))
TR = dict(distribution="trowbridge_reitz", shadowing="smith_correlated", fresnel="none",
          alpha_x=0.1, alpha_y=0.35, ks=(1.0, 1.0, 1.0))
BRUSHED_WARD = dict(alpha_x=0.04, alpha_y=0.3, ks=(1.0, 1.0, 1.0))
BRUSHED_TR = dict(distribution="trowbridge_reitz", shadowing="smith_correlated",
                  fresnel="none", alpha_x=0.04, alpha_y=0.3, ks=(1.0, 1.0, 1.0))

# Codes of the OSL enums (osl/rm_generated.h).
_ENUMS = {
    "distribution": {"blinn": 0, "gaussian": 1, "trowbridge_reitz": 2, "beckmann": 3},
    "shadowing": {"none": 0, "smith": 1, "smith_correlated": 2, "vgroove": 3, "smith_1967": 4},
    "fresnel": {"none": 0, "dielectric": 1, "conductor": 2},
}

# (model id for reference/OSL, parameters) of the cylinder comparisons
CYLINDER_MODELS = {
    "kajiya_kay": ("kajiya_kay", KK),
    "ward": ("ward", WARD),
    "microfacet_tr": ("microfacet", TR),
}
# Directions toward the sun, chosen near the cylinder's mirror cone for the
# view below (T.H = 0, 0.07, -0.04): an anisotropic lobe narrow along the
# axis only shows a highlight there (slide "Reflection from a Cylinder").
CYLINDER_SUNS = {
    "sun_a": (-0.574, 0.40, 0.715),
    "sun_b": (-0.45, -0.50, 0.74),
    "sun_c": (-0.65, 0.20, 0.733),
}
CYLINDER_VIEW = (math.sin(math.radians(35.0)), 0.0, math.cos(math.radians(35.0)))
CYLINDER_RADIUS = 0.3
CYLINDER_SEGMENTS = 128

RING_RADIUS = 0.7
RING_TUBE = 0.05
RING_VIEW = (0.0, -math.sin(math.radians(45.0)), math.cos(math.radians(45.0)))
RING_SUN = (0.6, 0.3, 0.75)

DISC_LIGHT = (0.45 * math.cos(math.radians(30.0)), 0.45 * math.sin(math.radians(30.0)), 0.5)
DISC_LIGHT_INTENSITY = 0.25  # W/sr: point-light irradiance = I / d^2

HAIR_VIEW = (0.0, -math.sin(math.radians(40.0)), math.cos(math.radians(40.0)))
HAIR_SUN = (0.35, 0.55, 0.76)


def _osl_value(model, name, value):
    if name in _ENUMS and model == "microfacet":
        return _ENUMS[name][value]
    return value


def osl_params(model, params):
    """The OSL parameter values for ``reference``-style ``params`` (enum
    strings become the shader's int codes; anisotropic widths select
    width_mode alpha_xy)."""
    out = {k: _osl_value(model, k, v) for k, v in params.items()}
    if model == "microfacet" and "alpha_x" in params:
        out["width_mode"] = 2
    return out


def reference_shade(model, wi, wo, normal, tangent, params):
    from addon import reference
    return reference.shade(model, wi, wo, normal=normal, tangent=tangent, **params)


# --------------------------------------------------------------------------
# materials

def new_material(name):
    """A material with an empty node tree (4.5 needs use_nodes)."""
    return common.empty_material(name, output=False)[0]


def _set_input(socket, value):
    dv = socket.default_value
    if hasattr(dv, "__len__"):
        value = tuple(float(x) for x in np.broadcast_to(np.asarray(value, dtype=float), (3,)))
        if len(dv) == 4:
            value = value + (1.0,)
    socket.default_value = value


VIA = "api"
"""How :func:`make_material` builds the shader by default: ``"api"``
(``addon.api.add_model``: the extension's node group, as a user gets it) or
``"script"`` (the model's OSL file as a bare internal Script node; socket
names = OSL parameter names)."""


def make_material(name, model, params, *, output="Direct", light=None, tangent=None,
                  normal=None, extra=None, via=None):
    """A material running the model ``model`` (catalogue id) with
    ``reference``-style ``params``.

    - ``output``: 'Direct' or 'BSDF' (closures, straight to the surface), or
      the name of a colour/float output of the shader, shown as an emission
      of strength 1; ``"pack:a,b"`` packs float outputs into RGB as
      ``0.5 + 0.5 x`` (for signed cosines).
    - ``light``: dict of light inputs (``light_direction``, ``point_light``,
      ``light_position``, ``light_strength``, ``shadows``...); ``extra``:
      other inputs by parameter name (``tangent_rotation``).
    - ``tangent`` / ``normal``: ``None`` (unconnected), a 3-vector
      (constant), or a function ``f(tree) -> output socket``.
    - ``via``: ``"api"`` or ``"script"`` (default :data:`VIA`).
    Returns ``(material, node)``: the group node (api) or the Script node.
    """
    via = via or VIA
    mat = new_material(name)
    tree = mat.node_tree
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    if via == "api":
        from addon import api, groups as rm_nodes
        mode = "path_traced" if output == "BSDF" else "exact"
        node = api.add_model(mat, model, mode=mode, **params)

        def inp(key):
            return rm_nodes.input_socket(node, key)

        def outp(key):
            return rm_nodes.output_socket(node, key)
    else:
        from addon.backends.osl import compile as oslutil
        node = oslutil.make_script_node(tree, "rm_" + model)
        for k, v in osl_params(model, params).items():
            _set_input(node.inputs[k], v)

        def inp(key):
            return node.inputs[key]

        def outp(key):
            return node.outputs[key]
    for k, v in list((light or {}).items()) + list((extra or {}).items()):
        _set_input(inp(k), v)
    for socket_name, src in (("tangent", tangent), ("shading_normal", normal)):
        if src is None:
            continue
        if callable(src):
            tree.links.new(src(tree), inp(socket_name))
        else:
            _set_input(inp(socket_name), src)
    if output in ("Direct", "BSDF"):
        tree.links.new(outp(output), out.inputs["Surface"])
    else:
        em = tree.nodes.new("ShaderNodeEmission")
        em.inputs["Strength"].default_value = 1.0
        if output.startswith("pack:"):
            comb = tree.nodes.new("ShaderNodeCombineXYZ")
            for i, oname in enumerate(output[5:].split(",")):
                ma = tree.nodes.new("ShaderNodeMath")
                ma.operation = 'MULTIPLY_ADD'
                ma.inputs[1].default_value = 0.5
                ma.inputs[2].default_value = 0.5
                tree.links.new(outp(oname), ma.inputs[0])
                tree.links.new(ma.outputs[0], comb.inputs[i])
            tree.links.new(comb.outputs[0], em.inputs["Color"])
        else:
            tree.links.new(outp(output), em.inputs["Color"])
        tree.links.new(em.outputs[0], out.inputs["Surface"])
    for n in tree.nodes:  # exactly one active output: ours
        if n.bl_idname == "ShaderNodeOutputMaterial":
            n.is_active_output = n == out
    mat.cycles.emission_sampling = 'NONE'
    return mat, node


def radial_normal_from_position(tree):
    """normalize(0, Py, Pz): the analytic normal of a cylinder along X."""
    geo = tree.nodes.new("ShaderNodeNewGeometry")
    mul = tree.nodes.new("ShaderNodeVectorMath")
    mul.operation = 'MULTIPLY'
    mul.inputs[1].default_value = (0.0, 1.0, 1.0)
    nrm = tree.nodes.new("ShaderNodeVectorMath")
    nrm.operation = 'NORMALIZE'
    tree.links.new(geo.outputs["Position"], mul.inputs[0])
    tree.links.new(mul.outputs[0], nrm.inputs[0])
    return nrm.outputs[0]


def ring_tangent_from_position(tree):
    """Z x P = (-Py, Px, 0): the direction of a circle about the Z axis."""
    geo = tree.nodes.new("ShaderNodeNewGeometry")
    cr = tree.nodes.new("ShaderNodeVectorMath")
    cr.operation = 'CROSS_PRODUCT'
    cr.inputs[0].default_value = (0.0, 0.0, 1.0)
    tree.links.new(geo.outputs["Position"], cr.inputs[1])
    return cr.outputs[0]


def radial_tangent_node(tree):
    """Blender's Tangent node, RADIAL about Z: tangents circling the Z axis
    (about the object's bounding-box centre), projected on the surface."""
    tn = tree.nodes.new("ShaderNodeTangent")
    tn.direction_type = 'RADIAL'
    tn.axis = 'Z'
    return tn.outputs["Tangent"]


def curve_tangent_node(tree):
    """Geometry node's Tangent output: on Cycles curves it is
    ``normalize(dPdu)``, the direction of the curve (measured in
    tests/test_anisotropy.py)."""
    geo = tree.nodes.new("ShaderNodeNewGeometry")
    return geo.outputs["Tangent"]


# --------------------------------------------------------------------------
# scenes

def new_scene(name, *, view_dir, ortho_scale, resolution, sun_dir=None, up_hint=None):
    scene = common.new_scene(name)
    common.configure_cycles(scene, samples=1, max_bounces=0, filter_width=0.01, osl=True)
    common.set_linear_exr_output(scene, resolution)
    common.set_world_background(scene, 0.0)
    _, basis = common.add_orthographic_camera(scene, view_dir, ortho_scale, up_hint=up_hint)
    if sun_dir is not None:
        common.add_sun(scene, sun_dir, 1.0)
    return scene, basis


def link_object(scene, name, data, material):
    bpy = common.import_bpy()
    data.materials.append(material)
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    return obj


def render_scene(scene, path=None):
    remove = path is None
    if path is None:
        path = common.temp_path(prefix="aniso_")
    try:
        seconds = common.render_to_exr(scene, path)
        img = common.read_exr(path, 3)
    finally:
        if remove and os.path.exists(path):
            os.remove(path)
    return img.astype(np.float64), seconds


def pixel_rays(basis, resolution, ortho_scale, offset=(0.0, 0.0), distance=10.0):
    """Origins (on the camera side) and the common direction of the pixel
    rays.  ``offset = (ox, oy)`` moves every pixel centre by ``ox`` pixels
    along the camera's right and ``oy`` along its up; each may be a scalar
    or an ``(H, W)`` array (see :func:`pixel_offsets`)."""
    w, h = resolution
    p = ortho_scale / w
    I, J = np.meshgrid(np.arange(w), np.arange(h))
    X = (I + 0.5 - w / 2.0 + offset[0]) * p
    Y = (h / 2.0 - J - 0.5 + offset[1]) * p
    right, up, wdir = basis[:, 0], basis[:, 1], basis[:, 2]
    origin = X[..., None] * right + Y[..., None] * up + distance * wdir
    return origin, -wdir


_OFFSETS = {}


def pixel_offsets(resolution):
    """Where Cycles' camera ray actually passes in each pixel, in pixels
    from the centre ``(ox right, oy up)``, each ``(H, W)``.

    The ray does not go through the pixel centre exactly, and on a curved
    surface or under a point light a sharp anisotropic lobe changes by up to
    0.3 % over that distance at these resolutions.  It is measured once per
    resolution: a plane facing an orthographic camera (width 2) emits its
    position + 2, which gives the ray's place in the pixel to ~1e-5 px.
    Measured (bpy 5.2, 1 sample, box filter 0.01 px): the same
    (+4.8e-4, +4.8e-4) px in every pixel, for every seed and camera width."""
    resolution = tuple(int(x) for x in resolution)
    if resolution in _OFFSETS:
        return _OFFSETS[resolution]
    bpy = common.import_bpy()
    w, h = resolution
    scene, basis = new_scene(f"aniso_offsets_{w}x{h}", view_dir=(0.0, 0.0, 1.0),
                          ortho_scale=2.0, resolution=resolution)
    mat = new_material(f"aniso_offsets_{w}x{h}")
    tree = mat.node_tree
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    geo = tree.nodes.new("ShaderNodeNewGeometry")
    add = tree.nodes.new("ShaderNodeVectorMath")
    add.operation = 'ADD'
    add.inputs[1].default_value = (2.0, 2.0, 2.0)
    em = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(geo.outputs["Position"], add.inputs[0])
    tree.links.new(add.outputs[0], em.inputs["Color"])
    tree.links.new(em.outputs[0], out.inputs["Surface"])
    mat.cycles.emission_sampling = 'NONE'
    mesh = bpy.data.meshes.new("aniso_offsets_plane")
    mesh.from_pydata([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [], [(0, 1, 2, 3)])
    link_object(scene, "aniso_offsets_plane", mesh, mat)
    img, _ = render_scene(scene)
    p = 2.0 / w
    I, J = np.meshgrid(np.arange(w), np.arange(h))
    ox = (img[..., 0] - 2.0) / p - (I + 0.5 - w / 2.0)
    oy = (img[..., 1] - 2.0) / p - (h / 2.0 - J - 0.5)
    _OFFSETS[resolution] = (ox, oy)
    return ox, oy


def eroded(hit_fn, basis, resolution, ortho_scale, erode):
    """Pixels whose rays at (+-erode, +-erode) pixels all hit."""
    ok = np.ones(resolution[::-1], dtype=bool)
    for dx in (-erode, erode):
        for dy in (-erode, erode):
            o, d = pixel_rays(basis, resolution, ortho_scale, (dx, dy))
            ok &= hit_fn(o, d)[0]
    return ok


# ---- the cylinder ----------------------------------------------------------

def prism_hit(origin, direction, radius, segments):
    """First hit of rays with the infinite regular prism along X whose
    cross-section is the ``segments``-gon with vertices at angles 2 pi k / n
    and radius ``radius``.  Returns (hit mask, t)."""
    o = origin[..., 1:]
    d = direction[1:]
    ang = 2.0 * np.pi * (np.arange(segments) + 0.5) / segments
    nrm = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # outward edge normals
    a = radius * math.cos(math.pi / segments)
    on = o @ nrm.T  # (..., n)
    dn = nrm @ d  # (n,)
    t_in = np.full(o.shape[:-1], -np.inf)
    t_out = np.full(o.shape[:-1], np.inf)
    ok = np.ones(o.shape[:-1], dtype=bool)
    for i in range(segments):
        if dn[i] < 0:
            t_in = np.maximum(t_in, (a - on[..., i]) / dn[i])
        elif dn[i] > 0:
            t_out = np.minimum(t_out, (a - on[..., i]) / dn[i])
        else:
            ok &= on[..., i] <= a
    return ok & (t_in <= t_out) & (t_in > 0), t_in


def tube_mesh(name, radius, segments, length):
    bpy = common.import_bpy()
    verts, faces = [], []
    for x in (-length / 2.0, length / 2.0):
        for k in range(segments):
            a = 2.0 * math.pi * k / segments
            verts.append((x, radius * math.cos(a), radius * math.sin(a)))
    for k in range(segments):
        k1 = (k + 1) % segments
        faces.append((k, k1, segments + k1, segments + k))  # outward normals
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    for p in mesh.polygons:
        p.use_smooth = True
    mesh.update()
    return mesh


class Cylinder:
    """The cylinder scene's geometry (numpy) and Blender scene."""

    def __init__(self, *, resolution=(96, 48), ortho_scale=1.6, view_dir=CYLINDER_VIEW,
                 radius=CYLINDER_RADIUS, segments=CYLINDER_SEGMENTS, erode=1.0):
        self.resolution = tuple(resolution)
        self.ortho_scale = ortho_scale
        self.radius, self.segments = radius, segments
        self.view_dir = common.normalize(view_dir)
        self.basis = common.camera_basis(self.view_dir)
        hit, self.position, self.normal = self._geometry((0.0, 0.0))
        self.mask = hit & eroded(lambda o, dd: prism_hit(o, dd, radius, segments),
                                  self.basis, self.resolution, ortho_scale, erode)
        self.tangent = np.array([1.0, 0.0, 0.0])
        self.wo = self.view_dir

    def _geometry(self, offset):
        origin, d = pixel_rays(self.basis, self.resolution, self.ortho_scale, offset)
        hit, t = prism_hit(origin, d, self.radius, self.segments)
        P = origin + np.where(hit, t, 0.0)[..., None] * d
        n = P * np.array([0.0, 1.0, 1.0])
        n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)
        return hit, P, n

    def expected(self, model, params, light_dir, offset=(0.0, 0.0)):
        """Expected image with every pixel centre moved by ``offset`` pixels."""
        m = self.mask
        out = np.zeros(m.shape + (3,))
        wi = common.normalize(light_dir)
        n = self._geometry(offset)[2]
        out[m] = reference_shade(model, wi, self.wo, n[m], self.tangent, params)
        return out

    def build(self, material, name="aniso_cylinder", sun_dir=None):
        scene, _ = new_scene(name, view_dir=self.view_dir, ortho_scale=self.ortho_scale,
                          resolution=self.resolution, sun_dir=sun_dir)
        link_object(scene, name + "_tube", tube_mesh(name + "_tube", self.radius,
                                                       self.segments, 8.0), material)
        return scene


# ---- the fibre ring ----------------------------------------------------------

def torus_mesh(name, R, r, n_major=192, n_minor=16):
    bpy = common.import_bpy()
    verts, faces = [], []
    for i in range(n_major):
        u = 2.0 * math.pi * i / n_major
        for j in range(n_minor):
            v = 2.0 * math.pi * j / n_minor
            rho = R + r * math.cos(v)
            verts.append((rho * math.cos(u), rho * math.sin(u), r * math.sin(v)))
    for i in range(n_major):
        i1 = (i + 1) % n_major
        for j in range(n_minor):
            j1 = (j + 1) % n_minor
            faces.append((i * n_minor + j, i1 * n_minor + j, i1 * n_minor + j1, i * n_minor + j1))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    for p in mesh.polygons:
        p.use_smooth = True
    mesh.update()
    return mesh


def torus_hit(origin, d, R, r, steps=400):
    """First hit of the rays with the analytic torus (march + bisection on
    the implicit function); returns (hit, points)."""
    def f(p):
        q = np.sqrt(p[..., 0] ** 2 + p[..., 1] ** 2) - R
        return q * q + p[..., 2] ** 2 - r * r
    t0, t1 = 8.0, 12.0  # the rays start 10 units from the origin
    ts = np.linspace(t0, t1, steps)
    prev = f(origin + t0 * d)
    lo = np.full(prev.shape, np.nan)
    for a, b in zip(ts[:-1], ts[1:]):
        cur = f(origin + b * d)
        new = np.isnan(lo) & (prev > 0) & (cur <= 0)
        lo[new] = a
        prev = cur
    hit = ~np.isnan(lo)
    a = np.where(hit, lo, t0)
    b = a + (ts[1] - ts[0])
    for _ in range(40):
        mid = 0.5 * (a + b)
        inside = f(origin + mid[..., None] * d) <= 0
        b = np.where(inside, mid, b)
        a = np.where(inside, a, mid)
    return hit, origin + b[..., None] * d


# ---- the brushed disc ----------------------------------------------------------

def disc_mesh(name, radius=1.0, segments=128):
    bpy = common.import_bpy()
    verts = [(0.0, 0.0, 0.0)] + [(radius * math.cos(2 * math.pi * k / segments),
                                   radius * math.sin(2 * math.pi * k / segments), 0.0)
                                  for k in range(segments)]
    faces = [(0, 1 + k, 1 + (k + 1) % segments) for k in range(segments)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    return mesh


# ---- hair curves ----------------------------------------------------------

def hair_curves(name, strands, radius):
    """A Curves datablock; ``strands`` = list of (n_i, 3) point arrays."""
    bpy = common.import_bpy()
    hc = bpy.data.hair_curves.new(name)
    hc.add_curves([len(s) for s in strands])
    pos = np.concatenate(strands).astype(np.float64)
    hc.position_data.foreach_set("vector", pos.ravel())
    rad = hc.attributes.get("radius") or hc.attributes.new("radius", 'FLOAT', 'POINT')
    rad.data.foreach_set("value", np.broadcast_to(np.asarray(radius, dtype=float),
                                                  (len(pos),)).tolist())
    return hc


def hair_fan(n=12, length=0.8, start=0.25, lift=0.25):
    """Straight strands radiating from the centre, rising by ``lift`` per
    unit length: their directions and the (2-point) strands."""
    dirs, strands = [], []
    for k in range(n):
        phi = 2.0 * math.pi * (k + 0.5) / n
        d = common.normalize((math.cos(phi), math.sin(phi), lift))
        dirs.append(d)
        strands.append(np.array([start * d, (start + length) * d]))
    return np.array(dirs), strands


def segment_mask(basis, resolution, ortho, strands, radius, erode_px=1.0, end_px=2.0):
    """Per pixel: the index of the straight strand whose projected core
    (radius - erode) covers the pixel centre, away from the ends; -1 elsewhere
    or where two strands overlap."""
    w, h = resolution
    p = ortho / w
    right, up = basis[:, 0], basis[:, 1]
    xs = (np.arange(w) + 0.5 - w / 2.0) * p
    ys = (h / 2.0 - np.arange(h) - 0.5) * p
    X, Y = np.meshgrid(xs, ys)
    idx = np.full((h, w), -1)
    count = np.zeros((h, w), dtype=int)
    for k, s in enumerate(strands):
        a = np.array([s[0] @ right, s[0] @ up])
        b = np.array([s[-1] @ right, s[-1] @ up])
        e = b - a
        L = np.linalg.norm(e)
        u = e / L
        rx, ry = X - a[0], Y - a[1]
        along = rx * u[0] + ry * u[1]
        across = np.abs(rx * u[1] - ry * u[0])
        cover = (across <= radius + p) & (along >= -radius - p) & (along <= L + radius + p)
        core = (across <= radius - erode_px * p) & (along >= end_px * p + radius) \
            & (along <= L - end_px * p - radius)
        count += cover
        idx[core] = k
    idx[count > 1] = -1
    return idx


def hair_lock(n=150, seed=3):
    """Strands of a wavy lock hanging along -Y over a bump (z = 0.35 (1 -
    y^2)), spread in X: the tangent tilts out of the image plane along each
    strand, so Kajiya-Kay's highlight is a band across the lock where the
    strands cross the mirror cone (for a camera on +Z and the demo's sun,
    near y = H_y / H_z)."""
    rng = np.random.default_rng(seed)
    strands = []
    for _ in range(n):
        x0 = rng.uniform(-0.55, 0.55)
        z0 = rng.uniform(-0.06, 0.06)
        phase = rng.uniform(0, 2 * math.pi)
        amp = rng.uniform(0.03, 0.06)
        ys = np.linspace(0.85, -0.85, 32)
        xs = x0 + amp * np.sin(5.0 * ys + phase) + 0.12 * ys * x0
        zs = z0 + 0.35 * (1.0 - ys * ys)
        strands.append(np.stack([xs, ys, zs], axis=1))
    return strands


HAIR_DEMO_SUN = (0.3, 0.5, 0.8)


def hair_band_expected_y():
    """Height of the highlight band on :func:`hair_lock` seen from +Z:
    T ~ (0, 1, dz/dy) = (0, 1, -0.7 y) (waves aside), T.H = 0 at
    y = H_y / (0.7 H_z)."""
    H = common.normalize(common.normalize(HAIR_DEMO_SUN) + np.array([0.0, 0.0, 1.0]))
    return float(H[1] / (0.7 * H[2]))


# --------------------------------------------------------------------------
# images

