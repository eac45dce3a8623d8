# SPDX-License-Identifier: GPL-3.0-or-later
"""Make ``tests/data/groups_v21_5.2.blend`` and ``groups_v21_4.5.blend``: a
file as the extension at commit b390546 (NODES_VERSION 21) saves it, built
through that version's own API, in each Blender series.

Run with a Python that has bpy (``.venv``: 5.2, ``.venv-4.5``: 4.5)::

    git worktree add /tmp/rm-v21 b390546
    .venv/bin/python tests/data/make_groups_v21.py /tmp/rm-v21 tests/data/groups_v21_5.2.blend
    .venv-4.5/bin/python tests/data/make_groups_v21.py /tmp/rm-v21 tests/data/groups_v21_4.5.blend

Ten spheres on a grid under a sun, a point and a spot lamp, each with a
model node in a mode (path traced, exact, hybrid), a backend (auto, osl,
native) and lamps bound to it, and on each node what a user makes: a Value
node linked to an input, a driver, keyframes (on inputs before and after
the Light inputs).  ``tests/test_upgrade.py`` opens it with the current
version and upgrades it.
"""

import importlib
import math
import os
import sys
import tempfile

WORKTREE, OUT = sys.argv[1], os.path.abspath(sys.argv[2])
sys.path.insert(0, WORKTREE)
os.environ["RM_PACKAGE_DIR"] = tempfile.mkdtemp(prefix="rm-package-v21-")

from verification.harness import session  # noqa: E402  (the old version's)
from verification.harness.package import build_zip  # noqa: E402

bpy = session.prepare()
extension = session.install_extension(build_zip())
api = importlib.import_module(extension + ".api")
socket = importlib.import_module(extension + ".groups").input_socket  # by parameter name

# (model, mode, backend, lamps bound, parameters, input linked from a Value
#  node, input with a driver, input with keyframes at frames 1 and 20)
NODES = (
    ("lambert", "exact", "native", ("Sun",), {}, None, None, "albedo"),
    ("phong", "exact", "osl", ("Point",), {"normalization": "energy"}, "exponent", None, None),
    ("blinn_phong", "hybrid", "auto", ("Sun", "Spot"), {}, None, "exponent", None),
    ("microfacet", "path_traced", "auto", (),
     {"distribution": "gaussian", "shadowing": "smith"}, None, None, "beta"),
    ("microfacet", "exact", "native", ("Sun", "Point", "Spot"),
     {"distribution": "trowbridge_reitz", "shadowing": "smith_correlated",
      "fresnel": "dielectric", "alpha_x": 0.2, "alpha_y": 0.5}, None, "alpha_x", "ior"),
    ("kajiya_kay", "exact", "auto", ("Spot",), {}, "kd", "tangent_rotation", "exponent"),
    ("ward", "hybrid", "osl", ("Point",), {}, "alpha_x", None, "alpha_y"),
    ("torrance_sparrow", "exact", "auto", ("Sun",), {}, None, None, "beta"),
    ("cook_torrance", "path_traced", "native", (), {}, None, "beta", None),
    ("microfacet", "exact", "auto", ("Sun", "Point"),
     {"distribution": "beckmann", "shadowing": "smith_1967", "alpha": 0.3}, "ks", None, None),
)


def lamp(scene, kind, name, location, rotation, energy):
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    if kind == "SPOT":
        data.spot_size, data.spot_blend = math.radians(80.0), 0.3
    ob = bpy.data.objects.new(name, data)
    scene.collection.objects.link(ob)
    ob.location, ob.rotation_euler = location, rotation
    return ob


def main():
    scene = bpy.context.scene
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob)
    lamps = {ob.name: ob for ob in (
        lamp(scene, "SUN", "Sun", (0.0, 0.0, 10.0), (0.4, 0.2, 0.3), 2.0),
        lamp(scene, "POINT", "Point", (3.0, -4.0, 6.0), (0.0, 0.0, 0.0), 400.0),
        lamp(scene, "SPOT", "Spot", (-1.0, -1.0, 9.0), (0.1, -0.1, 0.0), 900.0))}
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 12.0
    cam.location = (0.0, 0.0, 20.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    for i, (model, mode, backend, bound, params, linked, driven, keyed) in enumerate(NODES):
        mat = bpy.data.materials.new(f"M{i}_{model}")
        node = api.add_model(mat, model, mode, backend=backend, **params)
        node.name = "RM"
        if bound:
            api.bind_light(node, *(lamps[name] for name in bound))
        tree = mat.node_tree
        index = {s.as_pointer(): j for j, s in enumerate(node.inputs)}
        if linked:
            target = socket(node, linked)
            value = tree.nodes.new("ShaderNodeValue")
            value.name = "User Value"
            first = target.default_value
            value.outputs[0].default_value = first[0] if hasattr(first, "__len__") else first
            tree.links.new(value.outputs[0], target)
        if driven:
            target = socket(node, driven)
            fc = tree.driver_add(f'nodes["RM"].inputs[{index[target.as_pointer()]}].default_value')
            fc.driver.expression = f"{target.default_value:.6g} * (1 + 0 * frame)"
        if keyed:
            target = socket(node, keyed)
            first = target.default_value
            if hasattr(first, "__len__"):
                first = tuple(first)
                target.keyframe_insert("default_value", frame=1)
                target.default_value = tuple(0.8 * c for c in first[:3]) + first[3:]
            else:
                target.keyframe_insert("default_value", frame=1)
                target.default_value = 0.8 * first
            target.keyframe_insert("default_value", frame=20)
            target.default_value = first
        centre = ((i % 4) * 3.0 - 4.5, (i // 4) * 3.0 - 3.0, 0.0)
        bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.2,
                                             location=centre)
        ob = bpy.context.active_object
        ob.name = f"Sphere {i}"
        bpy.ops.object.shade_smooth()
        ob.data.materials.append(mat)
    api.sync_light_linking()
    scene.frame_set(1)
    bpy.ops.wm.save_as_mainfile(filepath=OUT, compress=True)


main()
session.cleanup()
os._exit(0)
