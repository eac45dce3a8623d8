# SPDX-License-Identifier: GPL-3.0-or-later
"""How long the hybrid mode's light linking takes in a scene of many
objects with the hybrid material (one triangle mesh shared, each object in
the scene): binding a sun (which brings the linking up to date), an update
with nothing to change (what the render and save handlers run), and the
sidebar's light-linking labels (what is out of date, and what Blender's
light linking cannot do as the mode wants), drawn at every redraw of the
panel, and the viewport's handler (``ui.on_depsgraph_update_post``) after
objects were added or removed (copied and deleted bound lamps put right),
at its first update, after an object's slot changed (the exclusions
brought up to date), at another update of the scene, and after objects
moved.  In a process of its own with
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


class _Update:
    """What a depsgraph's update of an object whose slots changed shows."""

    def __init__(self, obj):
        self.id = obj
        self.is_updated_shading, self.is_updated_geometry = True, False


class _Graph:
    """A viewport depsgraph with ``updates``, and the scene updated or not
    (adding or removing objects and changing slots update it)."""

    mode = 'VIEWPORT'

    def __init__(self, updates=(), scene=True):
        self.updates, self.scene = list(updates), scene

    def id_type_updated(self, id_type):
        return self.scene if id_type == 'SCENE' else bool(self.updates)


def _row(api, ui, n):
    """Seconds with ``n`` objects: bind, update, sidebar labels, and the
    viewport's handler after objects were added, at its first update (after
    a file was opened, an undo), after one object's slot changed, at an
    update of the scene with nothing added and no slot changed, and after
    every object moved; all removed."""
    import bpy
    scene = bpy.data.scenes.new(f"rm_bench_linking_{n}")
    sun = bpy.data.objects.new("rm_bench_sun", bpy.data.lights.new("rm_bench_sun", "SUN"))
    scene.collection.objects.link(sun)
    mat = bpy.data.materials.new("rm_bench_linking")
    plain = bpy.data.materials.new("rm_bench_linking_plain")
    mesh = bpy.data.meshes.new("rm_bench_linking")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    mesh.materials.append(mat)
    objects = [bpy.data.objects.new(f"rm_bench_{i}", mesh) for i in range(n)]
    for obj in objects:
        scene.collection.objects.link(obj)
    node = api.add_model(mat, "lambert", mode="hybrid")
    t = [time.perf_counter()]
    api.bind_light(node, sun)
    t.append(time.perf_counter())
    api.sync_light_linking()
    t.append(time.perf_counter())
    ui._draw_hybrid_linking(_Layout(), scene, node, [sun])
    t.append(time.perf_counter())
    ui._objects_seen[0] = None  # as after an object was added
    ui.on_depsgraph_update_post(scene, _Graph())
    t.append(time.perf_counter())
    ui._objects_seen[0] = ui._slots_seen[0] = None  # as after an undo
    ui.on_depsgraph_update_post(scene, _Graph())
    t.append(time.perf_counter())
    objects[0].material_slots[0].link = 'OBJECT'
    objects[0].material_slots[0].material = plain
    t.append(time.perf_counter())
    ui.on_depsgraph_update_post(scene, _Graph([_Update(objects[0])]))
    t.append(time.perf_counter())
    ui.on_depsgraph_update_post(scene, _Graph())  # nothing added, no slot changed
    t.append(time.perf_counter())
    moved = _Graph([_Update(o) for o in objects], scene=False)  # every object moved
    t.append(time.perf_counter())
    ui.on_depsgraph_update_post(scene, moved)
    t.append(time.perf_counter())
    api.unbind_light(node)
    bpy.data.batch_remove(objects + [sun, sun.data, mesh, mat, plain])
    bpy.data.scenes.remove(scene)
    d = [b - a for a, b in zip(t, t[1:])]
    return d[0], d[1], d[2], d[3], d[4], d[6], d[7], d[9]


def main(argv=None):
    from verification.harness import session as bpy_env
    bpy_env.prepare()
    import bpy

    from addon import api, ui
    _row(api, ui, 10)  # the extension's one-time costs
    print("\nThe hybrid mode's light linking: objects with the hybrid material, one sun bound")
    print(f"{'objects':>8s} {'bind':>8s} {'update':>8s} {'sidebar':>8s}   viewport: "
          f"{'added':>8s} {'first':>8s} {'slot':>8s} {'scene':>8s} {'moved':>7s}")
    for n in SIZES:
        bind, update, check, added, first, slot, scene, moved = _row(api, ui, n)
        print(f"{n:8d} {bind:7.3f}s {update:7.3f}s {check:7.3f}s             "
              f"{added * 1e3:6.2f}ms {first:7.3f}s {slot:7.3f}s {scene * 1e6:6.1f}µs "
              f"{moved * 1e6:5.1f}µs")
    print(f"(bpy {'.'.join(map(str, bpy.app.version))}; update: nothing to change, as the "
          "render and save handlers mostly find; sidebar: its light-linking labels, drawn at "
          "every redraw of the panel; viewport: its handler after objects were added or "
          "removed, at its first update (after a file was opened, an undo or a redo), after "
          "an object's slot changed (one exclusion removed), at an update of the scene with "
          "nothing added and no slot changed, and after every object moved (the scene not "
          "updated); measured, not asserted)")
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
