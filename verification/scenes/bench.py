# SPDX-License-Identifier: GPL-3.0-or-later
"""The render-cost scene of ``make bench``: every pixel shades the material.

A smooth UV sphere of radius 1 (64 segments, with a UV map, so the models
that use the UV tangent get one) seen by an orthographic camera whose frame
lies inside the silhouette (ortho scale 1.2: the corners are 0.85 from the
centre), a sun of angle 0, direct light only (no bounces), no world light.
The scene renders ``frames`` frames as one animation with persistent data,
so Cycles compiles the shaders (OSL's optimisation and JIT) and builds the
scene once, in the first frame; :func:`frame_cpu_seconds` returns the CPU
time of each frame, so the cost of rendering and the one-time set-up can be
told apart.
"""

from __future__ import annotations

import os
import time

from .. import harness as common
from .furnace import uv_sphere_mesh

LIGHT = (0.35, 0.25, 0.90)
ORTHO_SCALE = 1.2


def build_bench_scene(material, *, resolution=128, samples=16, frames=4, osl=None,
                      light_dir=LIGHT, name="bench", threads=0):
    """A new scene rendering ``material`` on the sphere; see the module.
    ``threads`` 0 uses every CPU thread; a positive number fixes the count."""
    bpy = common.import_bpy()
    scene = common.new_scene(name)
    if osl is None:
        osl = common.material_uses_osl(material)
    common.configure_cycles(scene, samples=samples, max_bounces=0, osl=osl)
    common.set_linear_exr_output(scene, (resolution, resolution))
    common.set_world_background(scene, 0.0)
    scene.render.use_persistent_data = True
    if threads:
        scene.render.threads_mode = 'FIXED'
        scene.render.threads = int(threads)
    scene.frame_start, scene.frame_end = 1, int(frames)
    common.add_orthographic_camera(scene, (0.0, 0.0, 1.0), ORTHO_SCALE)
    common.add_sun(scene, common.normalize(light_dir), 1.0)
    mesh = uv_sphere_mesh(name + "_sphere", 64, uvs=True)
    material.cycles.emission_sampling = 'NONE'
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name + "_sphere", mesh)
    scene.collection.objects.link(obj)
    return scene


def frame_cpu_seconds(scene, out_dir):
    """Render ``scene``'s frames as one animation into ``out_dir`` and return
    the process CPU time (every render thread) of each frame, in order."""
    bpy = common.import_bpy()
    stamps = []

    def stamp(*_args):
        stamps.append(time.process_time())

    scene.render.filepath = os.path.join(out_dir, scene.name + "_")
    bpy.app.handlers.render_pre.append(stamp)
    bpy.app.handlers.render_post.append(stamp)
    try:
        bpy.ops.render.render(animation=True, scene=scene.name)
    finally:
        bpy.app.handlers.render_pre.remove(stamp)
        bpy.app.handlers.render_post.remove(stamp)
    frames = scene.frame_end - scene.frame_start + 1
    if len(stamps) != 2 * frames:
        raise RuntimeError(f"expected {frames} rendered frames, saw {len(stamps) // 2}")
    return [b - a for a, b in zip(stamps[0::2], stamps[1::2])]
