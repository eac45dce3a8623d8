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


def _resolve_paths(bpy, snap, groups):
    """Driver and keyframe paths name socket indices: turn them into keys."""
    for name, entry in snap.items():
        node = bpy.data.materials[name].node_tree.nodes["RM"]
        def key(path):
            i = int(path.split(".inputs[")[1].split("]")[0])
            return groups.socket_key(node, node.inputs[i])
        entry["drivers"] = sorted((key(p), i, e) for p, i, e in entry["drivers"])
        entry["keys"] = sorted((key(p), k) for p, k in entry["keys"])
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
