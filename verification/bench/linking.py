# SPDX-License-Identifier: GPL-3.0-or-later
"""How long the hybrid mode's light linking takes in a scene of many
objects with the hybrid material (one triangle mesh shared, each object in
the scene): binding a sun (which brings the linking up to date), an update
with nothing to change (what the render and save handlers run), and the
sidebar's light-linking labels (what is out of date, and what Blender's
light linking cannot do as the mode wants), drawn at every redraw of the
panel, and the viewport's handler (``ui.on_depsgraph_update_post``) at an
update after objects were added or removed (copied and deleted bound
lamps put right) and at any other update.  In a process of its own with
nothing else in the file.  Measures and prints; asserts nothing.
"""

from __future__ import annotations

import sys
import time

SIZES = (200, 2_000, 10_000)


class _Layout:
    """Takes what the sidebar draws, and drops it."""

    def label(self, **_kwargs):
        pass

    def operator(self, *_args, **_kwargs):
        pass


def _row(api, ui, n):
    """(bind, update, sidebar labels, viewport handler after objects were
    added, at another update) seconds with ``n`` objects; all removed."""
    import bpy
    scene = bpy.data.scenes.new(f"rm_bench_linking_{n}")
    sun = bpy.data.objects.new("rm_bench_sun", bpy.data.lights.new("rm_bench_sun", "SUN"))
    scene.collection.objects.link(sun)
    mat = bpy.data.materials.new("rm_bench_linking")
    mesh = bpy.data.meshes.new("rm_bench_linking")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    mesh.materials.append(mat)
    objects = [bpy.data.objects.new(f"rm_bench_{i}", mesh) for i in range(n)]
    for obj in objects:
        scene.collection.objects.link(obj)
    node = api.add_model(mat, "lambert", mode="hybrid")
    t0 = time.perf_counter()
    api.bind_light(node, sun)
    t1 = time.perf_counter()
    api.sync_light_linking()
    t2 = time.perf_counter()
    ui._draw_hybrid_linking(_Layout(), scene, node, [sun])
    t3 = time.perf_counter()
    ui._objects_seen[0] = None  # as after an object was added
    ui.on_depsgraph_update_post(scene, None)
    t4 = time.perf_counter()
    ui.on_depsgraph_update_post(scene, None)  # the same objects
    t5 = time.perf_counter()
    api.unbind_light(node)
    bpy.data.batch_remove(objects + [sun, sun.data, mesh, mat])
    bpy.data.scenes.remove(scene)
    return t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4


def main(argv=None):
    from verification.harness import session as bpy_env
    bpy_env.prepare()
    import bpy

    from addon import api, ui
    _row(api, ui, 10)  # the extension's one-time costs
    print("\nThe hybrid mode's light linking: objects with the hybrid material, one sun bound")
    print(f"{'objects':>8s} {'bind':>8s} {'update':>8s} {'sidebar':>8s} {'vp added':>9s} "
          f"{'vp other':>9s}")
    for n in SIZES:
        bind, update, check, added, other = _row(api, ui, n)
        print(f"{n:8d} {bind:7.3f}s {update:7.3f}s {check:7.3f}s {added * 1e3:7.2f}ms "
              f"{other * 1e6:7.1f}µs")
    print(f"(bpy {'.'.join(map(str, bpy.app.version))}; update: nothing to change, as the "
          "render and save handlers mostly find; sidebar: its light-linking labels, drawn at "
          "every redraw of the panel; vp added: the viewport's handler after objects were "
          "added or removed; vp other: at any other update; measured, not asserted)")
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
