# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender for the measurement scenes: bpy start-up, Cycles settings,
camera and light placement, rendering to an EXR.

Conventions
-----------
- Directions are unit 3-vectors in world space.  ``view_dir`` points from
  the scene *toward* the camera (= wo of every pixel, the camera is
  orthographic); ``light_dir`` points *toward* the sun (= wi).
- Images are numpy arrays of shape ``(H, W, C)`` with **row 0 at the top** of
  the picture (the order OpenImageIO reads an EXR written by Blender) and
  column 0 at the left.  Pixel ``(row j, column i)`` has its centre at
  camera-plane coordinates ``x = (i + 0.5 - W/2) * p``,
  ``y = (H/2 - j - 0.5) * p`` with ``p = ortho_scale / W`` (the camera's
  sensor fit is forced to HORIZONTAL), along the camera's right and up axes.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

from .geometry import camera_basis, normalize  # noqa: F401  (re-exported)
from .images import read_exr, temp_path

_BPY = None


def import_bpy():
    """Return the ``bpy`` module.  Outside Blender it is imported once by
    ``verification.harness.session.prepare()`` (throwaway TMPDIR and user folders, Blender's
    bundled site-packages first on ``sys.path``); a bpy already imported
    (inside Blender, or by the caller) is reused as it is."""
    global _BPY
    if _BPY is None:
        from . import session as bpy_env
        if "bpy" in sys.modules:
            bpy_env.use_bundled_site_packages()
            import bpy
            _BPY = bpy
        else:
            _BPY = bpy_env.prepare()
    return _BPY


def _matrix_world(basis, position):
    from mathutils import Matrix
    m = np.eye(4)
    m[:3, :3] = basis
    m[:3, 3] = position
    return Matrix(m.tolist())


def new_scene(name):
    """A new, empty scene with Cycles on the CPU and a World of its own."""
    bpy = import_bpy()
    scene = bpy.data.scenes.new(name)
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    world = bpy.data.worlds.new(name + "_world")
    if bpy.app.version < (5, 0):  # always True (and deprecated) from 5.0
        world.use_nodes = True
    scene.world = world
    return scene


def configure_cycles(scene, *, samples=1, max_bounces=0, filter_width=0.01,
                     osl=False, seed=0):
    """Deterministic Cycles settings.

    ``max_bounces = 0`` (and every other bounce limit 0) gives direct light
    only; a SUN with angle 0 is then sampled exactly once per pixel, so one
    sample is exact.  ``filter_width = 0.01`` pixel puts the camera ray at the
    pixel centre.  No denoising, no adaptive sampling, no clamping.  Sets
    the scene's engine to Cycles (a new scene's is EEVEE).
    """
    scene.render.engine = 'CYCLES'
    c = scene.cycles
    c.device = 'CPU'
    c.shading_system = bool(osl)
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.use_preview_denoising = False
    c.seed = seed
    c.use_animated_seed = False
    c.max_bounces = max_bounces
    for attr in ("diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces", "transparent_max_bounces"):
        setattr(c, attr, max_bounces)
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.pixel_filter_type = 'BOX'
    c.filter_width = filter_width
    c.film_exposure = 1.0
    c.use_auto_tile = False
    scene.render.film_transparent = False
    scene.render.use_persistent_data = False


def set_linear_exr_output(scene, resolution):
    """Float32 RGB EXR output of linear radiance at ``resolution`` (W, H):
    view transform Standard, look None, exposure 0, gamma 1, no compositor,
    no sequencer, no dithering."""
    w, h = resolution
    r = scene.render
    r.resolution_x = int(w)
    r.resolution_y = int(h)
    r.resolution_percentage = 100
    r.pixel_aspect_x = 1.0
    r.pixel_aspect_y = 1.0
    r.use_border = False
    r.use_compositing = False
    r.use_sequencer = False
    r.dither_intensity = 0.0
    scene.view_settings.view_transform = 'Standard'
    scene.view_settings.look = 'None'
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    s = r.image_settings
    if hasattr(s, "media_type"):  # Blender >= 5.0
        s.media_type = 'IMAGE'
    s.file_format = 'OPEN_EXR'
    s.color_mode = 'RGB'
    s.color_depth = '32'
    s.exr_codec = 'ZIP'


def set_world_background(scene, strength, color=(1.0, 1.0, 1.0)):
    """Uniform world of ``color * strength``.  Strength 0 also switches the
    world off as a light (a new 5.x World holds a grey 0.05 Background)."""
    world = scene.world
    nodes = world.node_tree.nodes
    bg = next((n for n in nodes if n.bl_idname == 'ShaderNodeBackground'), None)
    if bg is None:
        bg = nodes.new('ShaderNodeBackground')
        out = next((n for n in nodes if n.bl_idname == 'ShaderNodeOutputWorld'), None)
        if out is None:
            out = nodes.new('ShaderNodeOutputWorld')
        world.node_tree.links.new(bg.outputs[0], out.inputs['Surface'])
    bg.inputs['Color'].default_value = (*color, 1.0)
    bg.inputs['Strength'].default_value = strength
    world.color = color if strength else (0.0, 0.0, 0.0)
    if hasattr(world, "probe_resolution"):
        # EEVEE renders the world into its reflection probe at every render
        # (at the default 1024: 0.9 s of a 48 x 48 render's 2.6 s on this
        # machine's software OpenGL); a uniform world is the same at any size
        world.probe_resolution = '128'
    if hasattr(world, "cycles"):
        world.cycles.sampling_method = 'AUTOMATIC' if strength else 'NONE'


def add_orthographic_camera(scene, view_dir, ortho_scale, *, distance=20.0, up_hint=None):
    """Orthographic camera on ``view_dir * distance`` looking at the origin,
    sensor fit HORIZONTAL (``ortho_scale`` spans the image width).
    Returns ``(camera_object, basis)``; basis columns = (right, up, view_dir)."""
    bpy = import_bpy()
    basis = camera_basis(view_dir, up_hint)
    cam = bpy.data.cameras.new(scene.name + "_camera")
    cam.type = 'ORTHO'
    cam.ortho_scale = float(ortho_scale)
    cam.sensor_fit = 'HORIZONTAL'
    cam.shift_x = cam.shift_y = 0.0
    cam.clip_start = 0.01
    cam.clip_end = 2.0 * distance
    obj = bpy.data.objects.new(scene.name + "_camera", cam)
    obj.matrix_world = _matrix_world(basis, basis[:, 2] * distance)
    scene.collection.objects.link(obj)
    scene.camera = obj
    return obj, basis


def add_sun(scene, light_dir, strength=1.0):
    """SUN lamp of angle 0 shining along ``-light_dir``: a surface facing it
    receives irradiance ``strength`` (W/m^2)."""
    bpy = import_bpy()
    sun = bpy.data.lights.new(scene.name + "_sun", 'SUN')
    sun.energy = float(strength)
    sun.angle = 0.0
    sun.color = (1.0, 1.0, 1.0)
    if hasattr(sun, "use_shadow"):
        sun.use_shadow = True
    obj = bpy.data.objects.new(scene.name + "_sun", sun)
    obj.matrix_world = _matrix_world(camera_basis(light_dir), normalize(light_dir) * 10.0)
    scene.collection.objects.link(obj)
    return obj


def material_uses_osl(material):
    """True when the material's node tree (or a nested group) holds a Script node."""
    seen = set()

    def walk(tree):
        if tree is None or tree.name in seen:
            return False
        seen.add(tree.name)
        for node in tree.nodes:
            if node.bl_idname == 'ShaderNodeScript':
                return True
            if node.bl_idname == 'ShaderNodeGroup' and walk(node.node_tree):
                return True
        return False

    return bool(material is not None and walk(material.node_tree))


def render_to_exr(scene, path):
    """Render ``scene`` with its engine (:func:`configure_cycles` or
    :func:`configure_eevee` sets it; a new scene's is EEVEE) into the EXR
    file ``path``; returns the wall time of the render call in seconds."""
    bpy = import_bpy()
    path = os.path.abspath(path)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    scene.render.filepath = path
    scene.render.use_file_extension = False
    t0 = time.perf_counter()
    result = bpy.ops.render.render(write_still=True, scene=scene.name)
    seconds = time.perf_counter() - t0
    if 'FINISHED' not in result or not os.path.exists(path):
        raise RuntimeError(f"render of scene {scene.name!r} failed: {result}")
    return seconds


def render_image(scene, prefix="render_"):
    """Render ``scene`` to a temporary float32 EXR, read it back and remove it.
    Returns ``(RGB (H, W, 3) float32 with row 0 = top, render seconds)``."""
    path = temp_path(prefix=prefix)
    try:
        seconds = render_to_exr(scene, path)
        return read_exr(path, 3), seconds
    finally:
        if os.path.exists(path):
            os.remove(path)


def empty_material(name, *, output=True):
    """A node material with an empty tree (Blender 4.5 needs ``use_nodes``),
    holding only a Material Output node when ``output``.  Returns
    ``(material, node_tree, output node or None)``."""
    bpy = import_bpy()
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    for node in list(tree.nodes):
        tree.nodes.remove(node)
    out = tree.nodes.new("ShaderNodeOutputMaterial") if output else None
    return mat, tree, out


def eevee_engine() -> str:
    """EEVEE's engine id: 'BLENDER_EEVEE' (5.x) or 'BLENDER_EEVEE_NEXT' (4.2-4.5)."""
    bpy = import_bpy()
    items = bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items.keys()
    return "BLENDER_EEVEE_NEXT" if "BLENDER_EEVEE_NEXT" in items else "BLENDER_EEVEE"


def configure_eevee(scene, *, samples=1, filter_size=0.01):
    """EEVEE for measurement: ``samples`` render samples, the pixel filter as
    narrow as it goes (the pixel shows its centre), no shadows of its own
    beyond the lamps', no world lighting (set the world's strength with
    :func:`set_world_background`), normals at full precision (by default
    the GPU gets them packed in 10 bits: 0.5 % off on tilted faces).  Its
    output is half float."""
    scene.render.engine = eevee_engine()
    if hasattr(scene.render, "use_high_quality_normals"):
        scene.render.use_high_quality_normals = True
    e = scene.eevee
    e.taa_render_samples = samples
    scene.render.filter_size = filter_size
    for attr, value in (("use_gtao", False), ("use_bloom", False), ("use_ssr", False),
                        ("use_shadows", True), ("use_raytracing", False)):
        if hasattr(e, attr):
            setattr(e, attr, value)
    scene.render.film_transparent = False
    scene.render.use_persistent_data = False
