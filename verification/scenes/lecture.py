# SPDX-License-Identifier: GPL-3.0-or-later
"""The lecture's rendered figures: the scenes, built through the public API.

- :func:`build_torrance_sparrow_scene`: one pixel per angle and material
  for the off-specular peak (slide "Torrance-Sparrow Experiments");
- :func:`build_glitter_scene`: the sun's glitter path on a rough sea
  (slides "Reflection of the Sun from the Sea", "Reflection Angles").

Their expectations come from :mod:`verification.experiments.lecture` on the
scenes' known geometry.
"""

from __future__ import annotations

import math

import numpy as np

from .. import harness
from ..experiments import lecture as X

DEG = math.pi / 180.0


def build_torrance_sparrow_scene(trs, ti, api):
    """One render for every angle: an orthographic camera straight above a row
    of small quads per material (aluminium in image row 1, MgO in row 2 of
    4), one quad per pixel.  Each quad carries face attributes
    ``rm_n`` (shading normal, at theta_r from the view direction +z) and
    ``rm_l`` (light direction, at theta_i from that normal on the other side),
    wired into the node's Normal and Light Direction inputs, so even
    theta_r = 89.9 deg is a full pixel and not a sliver of a tilted tile.
    ``api``: the extension's scripting API.  Returns the scene."""
    from addon import groups

    bpy = harness.import_bpy()
    K = len(trs)
    scene = harness.new_scene("rm_lecture_ts")
    harness.configure_cycles(scene, samples=1, max_bounces=0, filter_width=0.01, osl=True)
    harness.set_linear_exr_output(scene, (K, 4))  # Blender renders at least 4 rows
    harness.set_world_background(scene, 0.0)
    harness.add_orthographic_camera(scene, (0.0, 0.0, 1.0), float(K))
    for row, name in enumerate(X.TS_MATERIALS):
        yc = 0.5 - row  # pixel row 0 (top) is y = +0.5
        verts, faces = [], []
        for k in range(K):
            xc = k + 0.5 - K / 2
            n0 = len(verts)
            verts += [(xc - 0.4, yc - 0.4, 0), (xc + 0.4, yc - 0.4, 0), (xc + 0.4, yc + 0.4, 0),
                      (xc - 0.4, yc + 0.4, 0)]
            faces.append((n0, n0 + 1, n0 + 2, n0 + 3))
        mesh = bpy.data.meshes.new("rm_ts_" + name)
        mesh.from_pydata(verts, [], faces)
        uv = mesh.uv_layers.new(name="UVMap")
        for loop in uv.data:
            loop.uv = (0.0, 0.0)
        for attr, vecs in (("rm_n", [(-math.sin(t), 0.0, math.cos(t)) for t in trs]),
                           ("rm_l", [(-math.sin(t + ti), 0.0, math.cos(t + ti)) for t in trs])):
            a = mesh.attributes.new(attr, 'FLOAT_VECTOR', 'FACE')
            a.data.foreach_set("vector", np.asarray(vecs, dtype=np.float32).ravel())
        mesh.update()
        obj = bpy.data.objects.new("rm_ts_" + name, mesh)
        scene.collection.objects.link(obj)
        mat = bpy.data.materials.new("rm_ts_" + name)
        mesh.materials.append(mat)
        node = api.add_model(mat, "torrance_sparrow", mode="exact", beta=X.TS_BETA,
                             **X.TS_MATERIALS[name])
        groups.input_socket(node, "shadows").default_value = 0.0
        for attr, socket in (("rm_n", "shading_normal"), ("rm_l", "light_direction")):
            an = mat.node_tree.nodes.new("ShaderNodeAttribute")
            an.attribute_type = 'GEOMETRY'
            an.attribute_name = attr
            mat.node_tree.links.new(an.outputs["Vector"], groups.input_socket(node, socket))
    return scene


def build_glitter_scene(res, api):
    """The sea: a 2 km square at z = 0 with the microfacet Beckmann model in
    exact mode bound to a sun at elevation e, a camera at height h looking at
    the sun's image.  Returns ``(scene, rays)``: the camera's pixel rays
    (:func:`verification.experiments.lecture.camera_rays`)."""
    bpy = harness.import_bpy()
    g = X.GLITTER
    e = g["sun_elevation_deg"] * DEG
    scene = harness.new_scene("rm_lecture_glitter")
    harness.configure_cycles(scene, samples=1, max_bounces=0, filter_width=0.01, osl=True)
    harness.set_linear_exr_output(scene, res)
    harness.set_world_background(scene, 0.0)

    size = 1000.0
    mesh = bpy.data.meshes.new("rm_sea")
    mesh.from_pydata([(-size, -size, 0), (size, -size, 0), (size, size, 0), (-size, size, 0)],
                     [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop, (u, v) in zip(uv.data, ((0, 0), (1, 0), (1, 1), (0, 1))):
        loop.uv = (u, v)
    mesh.update()
    sea = bpy.data.objects.new("rm_sea", mesh)
    scene.collection.objects.link(sea)
    mat = bpy.data.materials.new("rm_sea_beckmann")
    sea.data.materials.append(mat)
    sun = harness.add_sun(scene, np.array([0.0, math.cos(e), math.sin(e)]), strength=1.0)
    node = api.add_model(mat, "microfacet", mode="exact", distribution="beckmann",
                         shadowing="smith", fresnel="none", beta=g["beta_deg"] * DEG)
    api.bind_light(node, sun)

    rays, basis, lens = X.camera_rays(res, g["vfov_deg"] * DEG, e)
    cam = bpy.data.cameras.new("rm_glitter_camera")
    cam.type = 'PERSP'
    cam.sensor_fit = 'HORIZONTAL'
    cam.sensor_width = 36.0
    cam.lens = lens
    cam.clip_start = 0.05
    cam.clip_end = 5000.0
    cam_obj = bpy.data.objects.new("rm_glitter_camera", cam)
    from mathutils import Matrix
    m = np.eye(4)
    m[:3, :3] = basis
    m[:3, 3] = (0.0, 0.0, g["eye_height"])
    cam_obj.matrix_world = Matrix(m.tolist())
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    return scene, rays
