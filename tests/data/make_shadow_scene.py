# SPDX-License-Identifier: GPL-3.0-or-later
"""Make ``tests/data/shadow_scene_5.2.blend`` and ``shadow_scene_4.5.blend``:
the shadow scene of ``tests/test_native.py`` (a plane with Lambert in exact
mode, backend 'auto', bound to a sun, and an occluder casting a square
shadow; OSL off), saved by the extension at ``NODES_VERSION`` 25 (commit
197630c) in each Blender series.  ``tests/test_native.py`` opens each in
the other series.

Run from the repository with a Python that has bpy (``.venv``: 5.2,
``.venv-4.5``: 4.5)::

    .venv/bin/python tests/data/make_shadow_scene.py tests/data/shadow_scene_5.2.blend
    .venv-4.5/bin/python tests/data/make_shadow_scene.py tests/data/shadow_scene_4.5.blend
"""

import os
import sys

OUT = os.path.abspath(sys.argv[1])
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]

from verification.harness import session  # noqa: E402

bpy = session.prepare()

from addon import api  # noqa: E402
import test_native  # noqa: E402

scene, _mat = test_native._shadow_scene(bpy, api, False)
for other in [s for s in bpy.data.scenes if s != scene]:
    bpy.data.scenes.remove(other)
bpy.ops.wm.save_as_mainfile(filepath=OUT, compress=True)
print("saved", OUT)
os._exit(0)
