# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared pieces of the measurement scenes: bpy start-up, Cycles settings,
camera and light placement, EXR output and reading, and the comparison of a
render with an expectation.

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
import tempfile
import time
from pathlib import Path

import numpy as np

_BPY = None


def import_bpy():
    """Return the ``bpy`` module.  Outside Blender it is imported once by
    ``tools.bpy_env.prepare()`` (throwaway TMPDIR and user folders, Blender's
    bundled site-packages first on ``sys.path``); a bpy already imported
    (inside Blender, or by the caller) is reused as it is."""
    global _BPY
    if _BPY is None:
        from tools import bpy_env
        if "bpy" in sys.modules:
            bpy_env.use_bundled_site_packages()
            import bpy
            _BPY = bpy
        else:
            _BPY = bpy_env.prepare()
    return _BPY


def _oiio():
    import_bpy()  # the bundled OpenImageIO must win over a pip-installed one
    import OpenImageIO
    return OpenImageIO


# --------------------------------------------------------------------------
# geometry helpers (numpy only)

def normalize(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def camera_basis(direction, up_hint=None):
    """Right-handed orthonormal basis ``(right, up, direction)`` as the columns
    of a 3x3 array, with ``direction`` normalised.

    Used for the camera (``direction`` = toward the camera, the camera looks
    along ``-direction``) and the sun (``direction`` = toward the sun).
    ``up`` is the projection of ``up_hint`` (default world +Y, or +Z when the
    direction is close to Y) on the plane perpendicular to ``direction``.
    With ``direction = (0,0,1)`` and the default hint the basis is identity.
    """
    w = normalize(direction)
    if up_hint is None:
        up_hint = (0.0, 1.0, 0.0) if abs(w[1]) < 0.9 else (0.0, 0.0, 1.0)
    up_hint = np.asarray(up_hint, dtype=np.float64)
    right = normalize(np.cross(up_hint, w))
    up = np.cross(w, right)
    return np.stack([right, up, w], axis=1)


def _matrix_world(basis, position):
    from mathutils import Matrix
    m = np.eye(4)
    m[:3, :3] = basis
    m[:3, 3] = position
    return Matrix(m.tolist())


# --------------------------------------------------------------------------
# scene set-up

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
    pixel centre.  No denoising, no adaptive sampling, no clamping.
    """
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


# --------------------------------------------------------------------------
# render and read

def render_to_exr(scene, path):
    """Render ``scene`` with Cycles into the EXR file ``path``; returns the
    wall time of the render call in seconds."""
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


def srgb_encode(linear):
    """Linear [0, 1] -> sRGB-encoded [0, 1] (IEC 61966-2-1), clipped."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def write_png(path, rgb, *, srgb=True):
    """Write ``rgb`` ``(H, W, 3)`` (row 0 = top; linear if ``srgb``, else
    already display-encoded in [0, 1]) as an 8-bit PNG."""
    oiio = _oiio()

    img = np.asarray(rgb, dtype=np.float64)[..., :3]
    if srgb:
        img = srgb_encode(img)
    data = np.ascontiguousarray(np.clip(np.round(img * 255.0), 0, 255).astype(np.uint8))
    h, w = data.shape[:2]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = oiio.ImageOutput.create(str(path))
    if out is None:
        raise OSError(f"cannot create {path}: {oiio.geterror()}")
    spec = oiio.ImageSpec(w, h, 3, "uint8")
    spec.attribute("png:compressionLevel", 9)
    if not out.open(str(path), spec):
        raise OSError(f"cannot open {path}: {out.geterror()}")
    ok = out.write_image(data)
    out.close()
    if not ok:
        raise OSError(f"cannot write {path}")
    return path


def read_exr(path, channels=3):
    """Read the first ``channels`` channels of an image as float32
    ``(H, W, channels)``, row 0 = top of the picture."""
    oiio = _oiio()
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot open {path}: {oiio.geterror()}")
    try:
        spec = inp.spec()
        data = inp.read_image(0, 0, 0, min(channels, spec.nchannels), "float")
    finally:
        inp.close()
    if data is None:
        raise OSError(f"cannot read {path}")
    data = np.asarray(data, dtype=np.float32).reshape(spec.height, spec.width, -1)
    return data


def temp_path(suffix=".exr", prefix="render_"):
    """A fresh file name under the process's temporary folder."""
    fd, path = tempfile.mkstemp(suffix=suffix, prefix=prefix)
    os.close(fd)
    os.remove(path)
    return path


# --------------------------------------------------------------------------
# comparison

def compare(rendered, expected, mask, *, floor=None, floor_fraction=1e-3):
    """Compare a render with an expectation on the pixels of ``mask``.

    The relative error of a pixel channel is ``|r - e| / max(|e|, floor)``.
    The floor keeps dark pixels (e.g. where N.wi <= 0 or far outside a
    highlight, e ~ 0) from dominating: by default it is ``floor_fraction``
    times the largest ``|e|`` over the mask (1e-3 of the peak), so below the
    floor an absolute error of ``floor_fraction * peak`` counts as 100 %.

    Returns a dict with ``max_rel_error``, ``rms_rel_error``,
    ``max_abs_error``, ``floor``, ``n_pixels`` (masked pixels), ``peak``
    (largest |e|), ``worst`` ((row, column, channel) of the largest relative
    error) and the rendered and expected values there.
    """
    r = np.asarray(rendered, dtype=np.float64)[..., :3]
    e = np.asarray(expected, dtype=np.float64)
    if e.ndim == r.ndim - 1:
        e = e[..., None]
    e = np.broadcast_to(e, r.shape)
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        raise ValueError("compare: empty mask")
    rm, em = r[mask], e[mask]
    peak = float(np.max(np.abs(em)))
    if floor is None:
        floor = floor_fraction * peak if peak > 0 else 1e-12
    abs_err = np.abs(rm - em)
    rel = abs_err / np.maximum(np.abs(em), floor)
    k = np.unravel_index(int(np.argmax(rel)), rel.shape)
    rows, cols = np.nonzero(mask)
    return {
        "max_rel_error": float(rel.max()),
        "rms_rel_error": float(np.sqrt(np.mean(rel ** 2))),
        "max_abs_error": float(abs_err.max()),
        "floor": float(floor),
        "peak": peak,
        "n_pixels": int(mask.sum()),
        "worst": (int(rows[k[0]]), int(cols[k[0]]), int(k[1])),
        "rendered_at_worst": float(rm[k]),
        "expected_at_worst": float(em[k]),
    }
