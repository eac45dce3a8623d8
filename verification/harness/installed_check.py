# SPDX-License-Identifier: GPL-3.0-or-later
"""The extension as a user's Blender has it: run as a script (not as a
module of this repository) by ``tests/test_packaging.py`` in a new process
whose ``sys.path`` holds no copy of the source tree, it installs the zip
through Blender's extension installer into new user folders, enables it,
adds every model and preset in each mode (every group built: the OSL
shaders and the native nodes), renders them under a sun with Open Shading
Language off and on, and prints one line ``INSTALLED-REPORT {json}``.

Arguments: the zip, and a folder for the user resources and the renders.
Imports nothing from this repository: a module of the extension that
imported the source tree's ``addon`` package would fail here, as it fails
in Blender.  :func:`run` starts it from the tests and ``make demo``.
"""

import importlib
import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

PREFIX = "INSTALLED-REPORT "


def run(zip_path, work, timeout=600) -> dict:
    """This file run as a script by this interpreter, from ``work`` (a new
    folder), without ``PYTHONPATH`` or the harness's user folders: the
    report it prints, as a dict.  Raises RuntimeError with the child's
    output if it fails."""
    env = {k: v for k, v in os.environ.items()
           if k != "PYTHONPATH" and not k.startswith("BLENDER_USER_")}
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), str(zip_path),
                           str(work)], cwd=work, env=env, capture_output=True, text=True,
                          timeout=timeout)
    lines = [line for line in proc.stdout.splitlines() if line.startswith(PREFIX)]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"the installed extension failed (exit {proc.returncode})\n"
                           + proc.stdout[-4000:] + proc.stderr[-4000:])
    return json.loads(lines[-1][len(PREFIX):])


def problems(report) -> list:
    """What is wrong in a :func:`run` report (empty: nothing): the source
    tree within reach, a render not finite, a node's tile unlit."""
    out = ["the source tree's addon package is importable"] if report["addon_importable"] else []
    for osl in (False, True):
        rendered = report[f"osl_{osl}"]
        if not rendered["finite"]:
            out.append(f"OSL {'on' if osl else 'off'}: pixels not finite")
        out += [f"OSL {'on' if osl else 'off'}: {key} unlit"
                for key, value in rendered["centres"].items() if not value > 0.0]
    return out


def main(zip_path, work):
    os.environ["BLENDER_USER_RESOURCES"] = os.path.join(work, "resources")
    import bpy
    import numpy as np

    report = {"addon_importable": importlib.util.find_spec("addon") is not None}
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                            enable_on_install=True)
    (name,) = [m for m in bpy.context.preferences.addons.keys()
               if m.endswith(".reflection_models")]
    api = importlib.import_module(name + ".api")
    catalogue = importlib.import_module(name + ".catalogue")
    report["module"] = name

    scene = bpy.context.scene
    for obj in list(scene.objects):
        bpy.data.objects.remove(obj)
    scene.world = None  # a black background
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.render.resolution_x, scene.render.resolution_y = 48, 8
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (math.radians(30.0), 0.0, 0.0)
    scene.collection.objects.link(sun)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = 12.0
    camera.location = (0.0, 0.0, 10.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    # the 48 x 8 pixels see x in [-6, 6] and y in [-1, 1]: 4 px a unit; tile (i, j) spans
    # x from -5.5 + 1.1 i and y from -1 + 1.2 j, one unit each
    models = list(catalogue.MODELS) + list(catalogue.PRESETS)
    centres = {}
    for i, model in enumerate(models):
        for j, mode in enumerate(("exact", "path_traced")):
            mat = bpy.data.materials.new(f"{model} {mode}")
            if mat.node_tree is None:
                mat.use_nodes = True
            node = api.add_model(mat, model, mode=mode)
            if mode == "exact":
                api.bind_light(node, sun)
            mesh = bpy.data.meshes.new(mat.name)
            x, y = -5.5 + i * 1.1, -1.0 + j * 1.2
            # the pixel at the visible part's centre (row 0 at the bottom, as Blender stores)
            centres[mat.name] = (int((x + 0.5 + 6.0) * 4.0), int((min(y + 0.5, 0.6) + 1.0) * 4.0))
            mesh.from_pydata([(x, y, 0), (x + 1, y, 0), (x + 1, y + 1, 0), (x, y + 1, 0)], [],
                             [(0, 1, 2, 3)])
            mesh.materials.append(mat)
            scene.collection.objects.link(bpy.data.objects.new(mat.name, mesh))
    report["nodes"] = len(centres)
    for osl in (False, True):
        scene.cycles.shading_system = osl
        scene.render.filepath = os.path.join(work, f"render_{int(osl)}.exr")
        bpy.ops.render.render(write_still=True)
        image = bpy.data.images.load(scene.render.filepath)
        pixels = np.array(image.pixels[:], dtype=np.float64).reshape(8, 48, 4)[..., :3]
        report[f"osl_{osl}"] = {
            "finite": bool(np.isfinite(pixels).all()),
            "centres": {key: float(pixels[row, col].max()) for key, (col, row) in centres.items()}}
    print(PREFIX + json.dumps(report), flush=True)


if __name__ == "__main__":
    try:
        main(sys.argv[1], sys.argv[2])
    except BaseException:
        import traceback
        traceback.print_exc()
        sys.stdout.flush()
        os._exit(1)
    os._exit(0)
