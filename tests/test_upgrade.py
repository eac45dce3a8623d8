# SPDX-License-Identifier: GPL-3.0-or-later
"""A file saved by the previous release (tests/data/groups_v3.blend, made by
the extension at commit 96d5b4b, NODES_VERSION 3, through its own API: one
material per model on a gonio scene, a Value node linked to a socket, a
driver, keyframes) opens, renders, is listed as outdated, upgrades in place,
keeps every value, link, driver and keyframe, and renders the same after
the upgrade."""

import importlib
from pathlib import Path

import numpy as np

from verification import harness

DATA = Path(__file__).resolve().parent / "data" / "groups_v3.blend"
GROUPS = 6  # one per model, two microfacet variants


def _snapshot(bpy, groups):
    """Everything a user made on the RM nodes, by material and socket key."""
    out = {}
    for mat in bpy.data.materials:
        if mat.node_tree is None or "RM" not in mat.node_tree.nodes:
            continue
        node = mat.node_tree.nodes["RM"]
        values = {}
        for s in node.inputs:
            if hasattr(s, "default_value"):
                v = s.default_value
                values[groups.socket_key(node, s)] = tuple(v) if hasattr(v, "__len__") else v
        links = sorted((groups.socket_key(node, l.to_socket), l.from_node.name)
                       for l in mat.node_tree.links if l.to_node == node)
        anim = mat.node_tree.animation_data
        drivers = sorted((fc.data_path, fc.array_index, fc.driver.expression)
                         for fc in (anim.drivers if anim else ()))
        keys = []
        if anim and anim.action:
            for fc in groups._action_fcurves(anim):
                keys.append((fc.data_path, [tuple(k.co) for k in fc.keyframe_points]))
        out[mat.name] = {"values": values, "links": links, "drivers": drivers,
                         "keys": sorted(keys), "group": node.node_tree.name}
    return out


def _path_key(groups, node, path):
    """The socket key of an F-curve path naming an input of ``node`` by index."""
    inner = path.split(".inputs[")[1].split("]")[0]
    if inner.startswith('"'):  # by identifier: not as the extension leaves paths
        return "identifier " + inner
    return groups.socket_key(node, node.inputs[int(inner)])


def _resolve_paths(bpy, snap, groups):
    """Driver and keyframe paths name socket indices: turn them into keys."""
    for name, entry in snap.items():
        node = bpy.data.materials[name].node_tree.nodes["RM"]
        entry["drivers"] = sorted((_path_key(groups, node, p), i, e)
                                  for p, i, e in entry["drivers"])
        entry["keys"] = sorted((_path_key(groups, node, p), k) for p, k in entry["keys"])
    return snap


def _render_all(bpy):
    images = {}
    for scene in bpy.data.scenes:
        if scene.name.startswith("gonio_"):
            scene.render.use_persistent_data = False
            img, _s = harness.render_image(scene, "upgrade_")
            images[scene.name] = img.astype(np.float64)
    return images


def test_a_file_of_the_previous_release_upgrades_keeping_everything(bpy, installed_extension):
    groups = importlib.import_module(installed_extension + ".groups")
    bpy.ops.wm.open_mainfile(filepath=str(DATA), load_ui=False)
    outdated = groups.find_outdated_groups()
    assert len(outdated) == GROUPS and all(int(t["rm_version"]) == 3 for t in outdated)
    before = _resolve_paths(bpy, _snapshot(bpy, groups), groups)
    old = _render_all(bpy)  # the old shaders, as saved in the file
    assert len(old) == 6 and all(np.isfinite(i).all() and i.max() > 0 for i in old.values())

    for tree in outdated:
        groups.upgrade_group(tree)
    assert not groups.find_outdated_groups()
    after = _resolve_paths(bpy, _snapshot(bpy, groups), groups)
    # values, links, drivers and keyframes, socket by socket; sockets the new
    # groups add (the spot's) are left out of the comparison
    for name, entry in after.items():
        added = set(entry["values"]) - set(before[name]["values"])
        assert added <= {"in:spot", "in:spot_size", "in:spot_blend"}, added
        entry["values"] = {k: v for k, v in entry["values"].items() if k not in added}
    assert after == before
    phong = next(e for n, e in after.items() if "phong" in n)
    assert phong["links"] == [("in:light_strength", "Strength")]
    assert phong["drivers"] and phong["keys"]  # the fixture does hold them

    new = _render_all(bpy)
    for name, img in old.items():
        peak = float(np.max(np.abs(img)))
        # old hand-written and new generated shaders: the same formulas in float32
        # (exact mode) or the same closures (path traced): rounding only, 1e-4 of the peak
        assert np.max(np.abs(new[name] - img)) <= 1e-4 * peak, name


# saved by each Blender series (Blender reads a newer series' file with "expect loss of
# data": 4.5 drops 5.2's Raycast node)
DATA_V21 = Path(__file__).resolve().parent / "data" / "groups_v21_{}.blend"
EXACT_V21 = (0, 1, 4, 5, 7, 9)  # the spheres in exact mode (tests/data/make_groups_v21.py)
NODES_BACKEND_V21 = ("native", "osl", "auto", "auto", "native", "auto", "osl", "auto", "native",
                     "auto")


def _state(bpy, groups, api):
    """:func:`_snapshot` with paths as socket keys, and what the lamps add:
    each node's mode, bound lamps, variant and what its outputs feed, each
    driver's variables, and the lamps' light linking."""
    snap = _resolve_paths(bpy, _snapshot(bpy, groups), groups)
    for name, entry in snap.items():
        tree = bpy.data.materials[name].node_tree
        node = tree.nodes["RM"]
        entry["mode"] = api.get_mode(node)
        entry["bound"] = [lamp.name for lamp in api.bound_lights(node)]
        entry["variant"] = groups.rm_info(node.node_tree)
        entry["feeds"] = sorted((link.from_socket.name, link.to_node.bl_idname)
                                for link in tree.links if link.from_node == node)
        entry["variables"] = sorted(
            (_path_key(groups, node, fc.data_path), fc.array_index, v.name, v.type,
             t.id.name if t.id else None, t.data_path, t.transform_type)
            for fc in tree.animation_data.drivers for v in fc.driver.variables
            for t in v.targets) if tree.animation_data else []
        del entry["group"]  # an upgrade keeps the group, a name may say its version
    linking = {}
    for lamp in bpy.data.objects:
        link = getattr(lamp, "light_linking", None)
        coll = link.receiver_collection if link else None
        if coll is not None:
            # collection_objects takes no keys: it walks the list ``objects`` walks
            linking[lamp.name] = sorted(
                (ob.name, entry.light_linking.link_state)
                for entry, ob in zip(coll.collection_objects, coll.objects))
    return snap, linking


def _render_both(scene):
    """The scene with OSL off and on: 120 px, 1 sample, linear float output
    (exact mode is then the same pixel for pixel from one render to the next).
    OSL is left on: the file has nodes forced to OSL, which with OSL off
    make the render handler warn in the tests that come after."""
    harness.set_linear_exr_output(scene, (120, 120))
    images = {}
    for osl in (False, True):
        harness.configure_cycles(scene, osl=osl, seed=3)
        images[osl] = harness.render_image(scene, "upgrade_v21_")[0].astype(np.float64)
    return images


def test_a_file_of_nodes_version_21_upgrades_keeping_everything(bpy, installed_extension):
    """tests/data/groups_v21_5.2.blend and groups_v21_4.5.blend (made by
    tests/data/make_groups_v21.py with the extension at b390546 in bpy 5.2.4
    and 4.5.15; each Blender opens its own): every mode, backend and lamp
    type, one to three lamps bound, links, drivers and keyframes on inputs
    before and after the Light inputs.  An upgrade keeps all of it, the lamps' light linking
    too, and exact mode renders as before, with OSL and natively."""
    groups = importlib.import_module(installed_extension + ".groups")
    api = importlib.import_module(installed_extension + ".api")
    series = "5.2" if bpy.app.version >= (5, 0) else "4.5"
    bpy.ops.wm.open_mainfile(filepath=str(DATA_V21).format(series), load_ui=False)
    outdated = groups.find_outdated_groups()
    assert len(outdated) == 10 and all(int(t["rm_version"]) == 21 for t in outdated)
    before, linking = _state(bpy, groups, api)
    assert {e["mode"] for e in before.values()} == {"exact", "hybrid", "path_traced"}
    assert sum(len(e["bound"]) for e in before.values()) == 12
    assert all(e["links"] or e["drivers"] or e["keys"] for e in before.values())
    assert linking  # the hybrid nodes' lamps have receivers
    scene = bpy.context.scene
    old = _render_both(scene)

    for tree in outdated:
        groups.upgrade_group(tree)
    api.sync_light_linking()
    assert not groups.find_outdated_groups()
    after, linking_after = _state(bpy, groups, api)
    assert after == before
    assert linking_after == linking

    new = _render_both(scene)
    for osl, img in new.items():
        assert np.isfinite(img).all() and np.isfinite(old[osl]).all()
        for i in EXACT_V21:
            # sphere i: radius 1.2 at ((i % 4) 3 - 4.5, (i // 4) 3 - 3), 10 px a unit
            x, y = int(((i % 4) * 3.0 - 4.5 + 6.0) * 10), int((6.0 - ((i // 4) * 3.0 - 3.0)) * 10)
            was, now = old[osl][y - 13:y + 13, x - 13:x + 13], img[y - 13:y + 13, x - 13:x + 13]
            if osl or NODES_BACKEND_V21[i] != "osl":  # (an OSL node renders black without OSL)
                assert np.max(was) > 1.5 * np.max(old[osl][:5, :5]), (osl, i)  # lit: over the sky
            # the same formulas in float32 before and after: rounding only, 1e-4 of the peak
            assert np.max(np.abs(now - was)) <= 1e-4 * np.max(was), (osl, i)
