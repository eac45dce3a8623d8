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
brought up to date), at another update of the scene, after objects
moved, and after a node or a light was edited among 10 to 1,000
materials (one of them with a bound node, or every one bound to four
lamps), and binding 100 and 400 hybrid nodes one by one, each binding
bringing the linking up to date or all in one
``api.deferred_light_linking()`` block.  In a process of its own with
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
    """A viewport depsgraph with ``updates``, the scene updated or not
    (adding or removing objects and changing slots update it), and the
    materials and node trees (a node edited) or not."""

    mode = 'VIEWPORT'

    def __init__(self, updates=(), scene=True, materials=False, lights=False,
                 collections=False):
        self.updates, self.scene, self.materials = list(updates), scene, materials
        self.lights, self.collections = lights, collections

    def id_type_updated(self, id_type):
        if id_type == 'SCENE':
            return self.scene
        if id_type in ('MATERIAL', 'NODETREE'):
            return self.materials
        if id_type == 'LIGHT':
            return self.lights
        if id_type == 'COLLECTION':
            return self.collections
        return bool(self.updates)


# what Blender's depsgraph says was updated after a bound lamp's energy was edited
# (measured, 5.2.4 and 4.5.15: the scene, the lamp, its light, materials and node trees; not
# the collections)
ENERGY_EDIT = dict(materials=True, lights=True)


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
    redrawn = _redrawn(ui, scene, node, sun)
    api.unbind_light(node)
    bpy.data.batch_remove(objects + [sun, sun.data, mesh, mat, plain])
    bpy.data.scenes.remove(scene)
    d = [b - a for a, b in zip(t, t[1:])]
    return d[0], d[1], d[2], redrawn, d[3], d[4], d[6], d[7], d[9]


def _redrawn(ui, scene, node, sun):
    """Seconds of a redraw of the sidebar's hybrid labels in the interactive
    UI, where they are kept from the redraw before (nothing updated
    between); the first draw, which reads them, untimed."""
    keeps = ui._keeps_reads
    ui._keeps_reads = lambda: True
    try:
        ui.forget_kept_reads()
        ui._draw_hybrid_linking(_Layout(), scene, node, [sun])
        t = time.perf_counter()
        ui._draw_hybrid_linking(_Layout(), scene, node, [sun])
        return time.perf_counter() - t
    finally:
        ui._keeps_reads = keeps
        ui.forget_kept_reads()


def _node_edit(api, ui, m):
    """Seconds of the viewport's handler at an update of a material's node
    tree (a node edited), and at one of a light (its energy edited), with
    nothing else changed, among ``m`` materials (a Principled BSDF each;
    one of them with a hybrid node bound to a sun in a collection of the
    scene); all removed."""
    import bpy
    scene = bpy.data.scenes.new(f"rm_bench_nodes_{m}")
    sun = bpy.data.objects.new("rm_bench_sun", bpy.data.lights.new("rm_bench_sun", "SUN"))
    rig = bpy.data.collections.new("rm_bench_rig")
    scene.collection.children.link(rig)
    rig.objects.link(sun)
    materials = [bpy.data.materials.new(f"rm_bench_nodes_{i}") for i in range(m)]
    for mat in materials:
        if mat.node_tree is None:  # 4.5: a new material has no nodes
            mat.use_nodes = True
    node = api.add_model(materials[0], "lambert", mode="hybrid")
    api.bind_light(node, sun)
    ui._slots_seen[0] = None
    ui.on_depsgraph_update_post(scene, _Graph())  # its first update: everything read
    t0 = time.perf_counter()
    ui.on_depsgraph_update_post(scene, _Graph(materials=True))
    t1 = time.perf_counter()
    ui.on_depsgraph_update_post(scene, _Graph(**ENERGY_EDIT))
    t2 = time.perf_counter()
    api.unbind_light(node)
    bpy.data.batch_remove(materials + [sun, sun.data, rig])
    bpy.data.scenes.remove(scene)
    return t1 - t0, t2 - t1


def _light_edit_bound(api, ui, m):
    """Seconds of the viewport's handler at an update of a light (its
    energy edited: nothing the bindings' check reads has changed, and it
    is not run), at one of a collection (a switch of one: no lamp's
    collections changed, and it is not run either), and at one of a
    collection after a lamp was moved into another (every binding read,
    the moved lamp's bound again in every node), among ``m`` materials
    each with an exact-mode node bound to the same four lamps (two suns,
    a point and a spot lamp, in a collection of the scene); all removed."""
    import bpy
    scene = bpy.data.scenes.new(f"rm_bench_bound_{m}")
    rig = bpy.data.collections.new("rm_bench_rig")
    away = bpy.data.collections.new("rm_bench_away")
    scene.collection.children.link(rig)
    scene.collection.children.link(away)
    lamps = []
    for i, kind in enumerate(("SUN", "POINT", "SPOT", "SUN")):
        lamps.append(bpy.data.objects.new(f"rm_bench_{i}", bpy.data.lights.new(f"rm_{i}", kind)))
        rig.objects.link(lamps[-1])
    materials = [bpy.data.materials.new(f"rm_bench_bound_{i}") for i in range(m)]
    for mat in materials:
        api.bind_light(api.add_model(mat, "lambert", mode="exact"), *lamps)
    ui._slots_seen[0] = None
    ui.on_depsgraph_update_post(scene, _Graph())  # its first update: everything read
    t0 = time.perf_counter()
    ui.on_depsgraph_update_post(scene, _Graph(**ENERGY_EDIT))
    t1 = time.perf_counter()
    away.hide_render = True
    ui.on_depsgraph_update_post(scene, _Graph(collections=True))
    t2 = time.perf_counter()
    away.objects.link(lamps[0])
    rig.objects.unlink(lamps[0])
    t3 = time.perf_counter()
    ui.on_depsgraph_update_post(scene, _Graph(collections=True))
    t4 = time.perf_counter()
    bpy.data.batch_remove(materials + lamps + [lamp.data for lamp in lamps] + [rig, away])
    bpy.data.scenes.remove(scene)
    return t1 - t0, t2 - t1, t4 - t3


def _bind_many(api, n, deferred):
    """Seconds to bind ``n`` hybrid nodes (each material on an object of
    its own) to one sun one by one, the light linking brought up to date
    after each binding or, ``deferred``, once at the end of an
    ``api.deferred_light_linking()`` block; all removed."""
    import bpy
    scene = bpy.data.scenes.new(f"rm_bench_many_{n}")
    sun = bpy.data.objects.new("rm_bench_many_sun", bpy.data.lights.new("rm_many", 'SUN'))
    scene.collection.objects.link(sun)
    materials, meshes, objects, nodes = [], [], [], []
    for i in range(n):
        materials.append(bpy.data.materials.new(f"rm_bench_many_{i}"))
        nodes.append(api.add_model(materials[-1], "lambert", mode="hybrid"))
        meshes.append(bpy.data.meshes.new(f"rm_bench_many_{i}"))
        meshes[-1].from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
        meshes[-1].materials.append(materials[-1])
        objects.append(bpy.data.objects.new(f"rm_bench_many_{i}", meshes[-1]))
        scene.collection.objects.link(objects[-1])
    t0 = time.perf_counter()
    if deferred:
        with api.deferred_light_linking():
            for node in nodes:
                api.bind_light(node, sun)
    else:
        for node in nodes:
            api.bind_light(node, sun)
    t1 = time.perf_counter()
    coll = sun.light_linking.receiver_collection
    assert coll is not None and len(coll.objects) == n, "the bench's bindings excluded too little"
    with api.deferred_light_linking():
        for node in nodes:
            api.unbind_light(node)
    bpy.data.batch_remove(materials + objects + meshes + [sun, sun.data])
    bpy.data.scenes.remove(scene)
    return t1 - t0


def main(argv=None):
    from verification.harness import session as bpy_env
    bpy_env.prepare()
    import bpy

    from addon import api, ui
    _row(api, ui, 10)  # the extension's one-time costs
    print("\nThe hybrid mode's light linking: objects with the hybrid material, one sun bound")
    print(f"{'objects':>8s} {'bind':>8s} {'update':>8s} {'sidebar':>8s} {'redrawn':>8s}   "
          f"viewport: {'added':>8s} {'first':>8s} {'slot':>8s} {'scene':>8s} {'moved':>7s}")
    for n in SIZES:
        bind, update, check, redrawn, added, first, slot, scene, moved = _row(api, ui, n)
        print(f"{n:8d} {bind:7.3f}s {update:7.3f}s {check:7.3f}s {redrawn * 1e6:6.1f}µs"
              f"             {added * 1e3:6.2f}ms {first:7.3f}s {slot:7.3f}s "
              f"{scene * 1e6:6.1f}µs {moved * 1e6:5.1f}µs")
    print(f"(bpy {'.'.join(map(str, bpy.app.version))}; update: nothing to change, as the "
          "render and save handlers mostly find; sidebar: its light-linking labels, read at "
          "the panel's first redraw after an update; redrawn: at the next ones, from what "
          "the interactive UI kept; viewport: its handler after objects were added or "
          "removed, at its first update (after a file was opened, an undo or a redo), after "
          "an object's slot changed (one exclusion removed), at an update of the scene with "
          "nothing added and no slot changed, and after every object moved (the scene not "
          "updated); measured, not asserted)")
    print("\nThe viewport's handler after a node or a light was edited, nothing else changed")
    print(f"{'materials':>9s} {'node':>9s} {'light':>9s} {'light, all bound':>17s} "
          f"{'switch, all bound':>22s} {'lamp moved, all bound':>22s}")
    for m in (10, 100, 1_000):
        node, light = _node_edit(api, ui, m)
        bound, collection, moved = _light_edit_bound(api, ui, m)
        print(f"{m:9d} {node * 1e3:7.2f}ms {light * 1e3:7.2f}ms {bound * 1e3:15.2f}ms "
              f"{collection * 1e3:20.2f}ms {moved * 1e3:20.2f}ms")
    print("(each material a Principled BSDF, one of them with a hybrid node bound to a sun: "
          "after a node edit the handler reads which materials have a bound hybrid node, "
          "after a light's energy was edited (the update Blender makes) which lamps' type, "
          "light data or collections changed; all bound: each material an exact-mode node "
          "bound to the same four lamps; switch: after a collection's Disable in Renders was "
          "switched, the same (none changed); after a lamp was moved to another collection "
          "every binding is read and the lamp bound again in each node; measured, not "
          "asserted)")
    print("\nBinding hybrid nodes one by one to a sun, each material on an object of its own")
    print(f"{'nodes':>9s} {'each bind':>10s} {'deferred':>9s}")
    for n in (100, 400):
        each, deferred = _bind_many(api, n, False), _bind_many(api, n, True)
        print(f"{n:9d} {each:9.2f}s {deferred:8.2f}s")
    print("(each bind: the light linking brought up to date after every binding, which "
          "reads every hybrid node; deferred: in one api.deferred_light_linking() block, "
          "brought up to date once at its end; measured, not asserted)")
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
