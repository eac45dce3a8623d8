# SPDX-License-Identifier: GPL-3.0-or-later
"""The gallery: a row of material balls, one per model, under studio light.

Smooth UV spheres side by side, seen from slightly above by an orthographic
camera; a warm area key light from the upper left, a cool sun rim from
behind, and a studio environment (a dark floor, a bright soft sky) that the
glossy models reflect.  Every ball uses its model's **path-traced** output
(the ``BSDF`` socket), rendered with a few samples: the picture an artist
judges the add-on by.  Each ball is labelled by a text object below it.

``build_gallery(api)`` builds the scene; ``render_gallery(gallery)`` returns
the linear RGB image (row 0 = top).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from .. import harness as common

DEG = math.pi / 180.0

# (label, model, params): the balls, left to right.
BALLS = (
    ("Lambert", "lambert", {"albedo": (0.75, 0.22, 0.15)}),
    ("Phong", "phong", {"normalization": "energy", "exponent": 60.0, "ks": (0.8, 0.8, 0.8)}),
    ("Blinn-Phong", "blinn_phong", {"normalization": "energy", "exponent": 120.0,
                                    "ks": (0.25, 0.45, 0.85)}),
    ("GGX gold", "microfacet", {"distribution": "trowbridge_reitz",
                                "shadowing": "smith_correlated", "fresnel": "conductor",
                                "ior": (0.166, 0.424, 1.38), "k": (3.15, 2.35, 1.91),
                                "alpha": 0.25}),
    ("Beckmann glass", "microfacet", {"distribution": "beckmann", "shadowing": "smith",
                                      "fresnel": "dielectric", "ior": 1.5, "beta": 8 * DEG}),
    ("Torrance-\nSparrow", "torrance_sparrow", {"fresnel": "conductor",
                                                "ior": (1.47, 0.96, 0.62),
                                                "k": (7.79, 6.69, 5.47), "beta": 15 * DEG}),
    ("Cook-\nTorrance", "cook_torrance", {"fresnel": "conductor", "ior": (0.214, 1.06, 1.19),
                                          "k": (3.67, 2.59, 2.41), "beta": 12 * DEG}),
    ("Ward", "ward", {"alpha_x": 0.35, "alpha_y": 0.08, "ks": (0.85, 0.85, 0.9)}),
    ("Kajiya-Kay", "kajiya_kay", {}),
)


@dataclass
class Gallery:
    scene: object
    labels: list
    resolution: tuple
    samples: int
    materials: list = field(default_factory=list)
    last_render_seconds: float = float("nan")


def _studio_world(scene):
    """A direction-dependent studio environment: dark floor, a soft bright
    sky brightening toward the zenith."""
    world = scene.world
    tree = world.node_tree
    for n in list(tree.nodes):
        tree.nodes.remove(n)
    out = tree.nodes.new("ShaderNodeOutputWorld")
    bg = tree.nodes.new("ShaderNodeBackground")
    coord = tree.nodes.new("ShaderNodeTexCoord")
    sep = tree.nodes.new("ShaderNodeSeparateXYZ")
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    remap = tree.nodes.new("ShaderNodeMapRange")
    remap.inputs["From Min"].default_value = -1.0
    remap.inputs["From Max"].default_value = 1.0
    el = ramp.color_ramp.elements
    el[0].position, el[0].color = 0.44, (0.02, 0.02, 0.025, 1.0)
    el[1].position, el[1].color = 1.0, (0.55, 0.6, 0.7, 1.0)
    mid = el.new(0.52)
    mid.color = (0.25, 0.25, 0.27, 1.0)
    tree.links.new(coord.outputs["Generated"], sep.inputs[0])
    tree.links.new(sep.outputs["Z"], remap.inputs["Value"])
    tree.links.new(remap.outputs["Result"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = 1.0
    tree.links.new(bg.outputs[0], out.inputs["Surface"])
    if hasattr(world, "cycles"):
        world.cycles.sampling_method = 'AUTOMATIC'


def _look_at(obj, target):
    import mathutils
    d = mathutils.Vector(target) - obj.location
    obj.rotation_euler = d.to_track_quat('-Z', 'Y').to_euler()


def _lamp(scene, name, kind, location, **settings):
    """A lamp of ``kind`` at ``location`` aimed at the origin, with the
    light data's ``settings``; returns its object."""
    import bpy
    light = bpy.data.lights.new(name, kind)
    for key, value in settings.items():
        setattr(light, key, value)
    obj = bpy.data.objects.new(name, light)
    obj.location = location
    scene.collection.objects.link(obj)
    _look_at(obj, (0.0, 0.0, 0.0))
    return obj


def _label_material(name):
    mat, tree, out = common.empty_material(name)
    em = tree.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (0.9, 0.9, 0.9, 1.0)
    em.inputs["Strength"].default_value = 1.0
    tree.links.new(em.outputs[0], out.inputs["Surface"])
    mat.cycles.emission_sampling = 'NONE'
    return mat


def build_gallery(api, *, resolution=(800, 160), samples=24, denoise=True, balls=BALLS,
                  name="gallery"):
    """Build the gallery scene; materials come from ``api.add_model(...,
    mode="path_traced")``."""
    bpy = common.import_bpy()

    w, h = resolution
    n = len(balls)
    scene = _scene(api, name, resolution, samples, denoise)
    _studio_world(scene)

    spacing = 1.0
    cam_data = bpy.data.cameras.new(name + "_camera")
    cam_data.type = 'ORTHO'
    cam_data.ortho_scale = n * spacing
    cam_data.sensor_fit = 'HORIZONTAL'
    cam = bpy.data.objects.new(name + "_camera", cam_data)
    elev = 12.0 * DEG
    cam.location = (0.0, -20.0 * math.cos(elev), 20.0 * math.sin(elev) + 0.0)
    scene.collection.objects.link(cam)
    _look_at(cam, (0.0, 0.0, 0.0))
    # shift the framing up a little to leave room for the labels below
    cam_data.shift_y = -0.025
    scene.camera = cam

    _lamp(scene, name + "_key", 'AREA', (-5.0, -6.0, 6.0), energy=900.0, size=4.0,
          color=(1.0, 0.95, 0.88))
    _lamp(scene, name + "_rim", 'SUN', (4.0, 8.0, 5.0), energy=2.0, angle=4.0 * DEG,
          color=(0.8, 0.88, 1.0))

    radius = 0.4
    label_mat = _label_material(name + "_label")
    labels, materials = [], [label_mat]
    for i, (label, model, params) in enumerate(balls):
        x = (i - (n - 1) / 2.0) * spacing
        mat, _node = _model_material(api, f"{name}_{i}_{model}", model, "path_traced", params)
        materials.append(mat)
        _ball(scene, f"{name}_ball_{i}", mat, (x, 0.0, 0.0), radius, segments=(64, 32))

        curve = bpy.data.curves.new(f"{name}_label_{i}", 'FONT')
        curve.body = label
        curve.align_x = 'CENTER'
        curve.align_y = 'TOP'
        curve.size = 0.12
        curve.materials.append(label_mat)
        txt = bpy.data.objects.new(f"{name}_label_{i}", curve)
        txt.location = (x, -0.5, -radius - 0.08)
        txt.rotation_euler = (math.pi / 2 - elev, 0.0, 0.0)
        scene.collection.objects.link(txt)
        labels.append(label.replace("\n", ""))
    return Gallery(scene=scene, labels=labels, resolution=(w, h), samples=samples,
                   materials=materials)


def render_gallery(gallery, path=None):
    """Render to a float32 EXR (a temporary file unless ``path``) and return
    linear RGB ``(H, W, 3)``, row 0 = top."""
    remove = path is None
    if path is None:
        path = common.temp_path(prefix="gallery_")
    try:
        try:
            gallery.last_render_seconds = common.render_to_exr(gallery.scene, path)
        except RuntimeError:
            if not gallery.scene.cycles.use_denoising:
                raise
            gallery.scene.cycles.use_denoising = False  # no denoiser in this build
            gallery.last_render_seconds = common.render_to_exr(gallery.scene, path)
        img = common.read_exr(path, 3)
    finally:
        if remove and os.path.exists(path):
            os.remove(path)
    return np.asarray(img)


# The three modes side by side: (label, model, params) per column.
MODE_BALLS = (
    ("Phong", "phong", {"normalization": "energy", "exponent": 60.0, "ks": (0.8, 0.8, 0.8)}),
    ("Blinn-Phong", "blinn_phong", {"normalization": "energy", "exponent": 120.0,
                                    "ks": (0.25, 0.45, 0.85)}),
    ("Gaussian", "microfacet", {"distribution": "gaussian", "shadowing": "smith",
                                "fresnel": "conductor", "ior": (0.166, 0.424, 1.38),
                                "k": (3.15, 2.35, 1.91), "beta": 18 * DEG}),
    ("V-groove", "microfacet", {"distribution": "beckmann", "shadowing": "vgroove",
                                "beta": 20 * DEG}),
    ("Ward", "ward", {"alpha_x": 0.35, "alpha_y": 0.08, "ks": (0.85, 0.85, 0.9)}),
    ("Kajiya-Kay", "kajiya_kay", {}),
)
MODES = (("path traced", "path_traced"), ("exact", "exact"), ("hybrid", "hybrid"))


def build_modes_gallery(api, *, resolution=(720, 400), samples=32, denoise=True,
                        balls=MODE_BALLS, name="modes"):
    """Rows: path traced, exact (the bound sun and point lamp only) and
    hybrid (those two exactly, the sky and bounces path traced); columns:
    models.  Under a sun, a point lamp of radius 0 and a uniform sky."""
    bpy = common.import_bpy()

    w, h = resolution
    n = len(balls)
    scene = _scene(api, name, resolution, samples, denoise)
    common.set_world_background(scene, 0.35, (0.55, 0.7, 1.0))

    spacing = 1.0
    cam_data = bpy.data.cameras.new(name + "_camera")
    cam_data.type = 'ORTHO'
    cam_data.ortho_scale = (n + 1) * spacing
    cam_data.sensor_fit = 'HORIZONTAL'
    cam = bpy.data.objects.new(name + "_camera", cam_data)
    cam.location = (-0.5 * spacing, -20.0, 0.0)
    scene.collection.objects.link(cam)
    _look_at(cam, (-0.5 * spacing, 0.0, 0.0))
    scene.camera = cam

    sun_obj = _lamp(scene, name + "_sun", 'SUN', (-4.0, -6.0, 6.0), energy=2.5, angle=0.0,
                    color=(1.0, 0.93, 0.85))
    point_obj = _lamp(scene, name + "_point", 'POINT', (4.0, -3.0, 1.5), energy=250.0,
                      shadow_soft_size=0.0, color=(0.7, 0.8, 1.0))

    radius = 0.4
    label_mat = _label_material(name + "_label")
    materials, labels = [label_mat], []
    for r, (row_label, mode) in enumerate(MODES):
        z = (1 - r) * 1.05
        txt = _text(bpy, f"{name}_row_{r}", row_label, label_mat,
                    (-(n + 1) / 2.0 * spacing + 0.05, -0.5, z), align="LEFT")
        scene.collection.objects.link(txt)
        for i, (label, model, params) in enumerate(balls):
            x = (i - (n - 1) / 2.0) * spacing
            mat, node = _model_material(api, f"{name}_{mode}_{i}_{model}", model, mode, params)
            materials.append(mat)
            # fine facets: Kajiya-Kay's lamps behind the surface are shadowed by
            # the body, with one step per facet row at the terminator
            _ball(scene, f"{name}_ball_{r}_{i}", mat, (x, 0.0, z), radius, segments=(192, 96))
            if mode != "path_traced":
                api.bind_light(node, sun_obj, point_obj)
            if r == len(MODES) - 1:
                txt = _text(bpy, f"{name}_label_{i}", label, label_mat,
                            (x, -0.5, z - radius - 0.1))
                scene.collection.objects.link(txt)
                labels.append(label)
    api.sync_light_linking()
    return Gallery(scene=scene, labels=labels, resolution=(w, h), samples=samples,
                   materials=materials)


def _scene(api, name, resolution, samples, denoise):
    """A Cycles scene for a gallery: OSL on, bounces, the denoiser if asked."""
    scene = common.new_scene(name)
    common.configure_cycles(scene, samples=samples, max_bounces=4, filter_width=1.5, osl=True)
    scene.cycles.use_denoising = bool(denoise)
    common.set_linear_exr_output(scene, tuple(resolution))
    api.enable_osl(scene)
    return scene


def _model_material(api, name, model, mode, params):
    """``(material, node)``: a material holding ``model`` in ``mode``,
    not sampled as a lamp."""
    bpy = common.import_bpy()
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    node = api.add_model(mat, model, mode=mode, **params)
    mat.cycles.emission_sampling = 'NONE'
    return mat, node


def _ball(scene, name, material, location, radius, segments):
    """A smooth UV sphere (``segments`` = (u, v)) with a "UVMap" layer and
    ``material``, tilted 25 degrees (so the tangent field is not axis
    aligned), linked to ``scene``."""
    bpy = common.import_bpy()
    import bmesh

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    try:
        u, v = segments
        try:
            bmesh.ops.create_uvsphere(bm, u_segments=u, v_segments=v, radius=radius,
                                      calc_uvs=True)
        except TypeError:  # older bmesh: the size argument is called diameter
            bmesh.ops.create_uvsphere(bm, u_segments=u, v_segments=v, diameter=radius,
                                      calc_uvs=True)
        for f in bm.faces:
            f.smooth = True
        bm.to_mesh(mesh)
    finally:
        bm.free()
    if not mesh.uv_layers:
        mesh.uv_layers.new(name="UVMap")
    mesh.uv_layers[0].name = "UVMap"
    mesh.materials.append(material)
    ball = bpy.data.objects.new(name, mesh)
    ball.location = location
    ball.rotation_euler = (0.0, 25.0 * DEG, 0.0)
    scene.collection.objects.link(ball)
    return ball


def _text(bpy, name, body, material, location, align="CENTER"):
    curve = bpy.data.curves.new(name, 'FONT')
    curve.body = body
    curve.align_x = align
    curve.align_y = 'TOP' if align == "CENTER" else 'CENTER'
    curve.size = 0.13
    curve.materials.append(material)
    txt = bpy.data.objects.new(name, curve)
    txt.location = location
    txt.rotation_euler = (math.pi / 2, 0.0, 0.0)
    return txt
