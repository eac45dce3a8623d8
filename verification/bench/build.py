# SPDX-License-Identifier: GPL-3.0-or-later
"""How long a node group takes to build: the time from ``api.add_model`` on
an empty material to its return, per variant, in a process of this Blender
with nothing else in the file (the OSL shaders compile then too).  Once in
nested parts of PART_SIZE nodes (what the extension does), once in one tree
(PART_SIZE larger than any plan), the group removed between the two.

Blender updates a whole node tree at every node, link and value a script
sets in it, so a tree of n nodes takes time growing with n squared to
build; the parts keep each update to one part
(:meth:`addon.backends.native.build.Builder.instantiate`).  An artist waits
for this once per variant and file.  Measures and prints; asserts nothing.
"""

from __future__ import annotations

import sys
import time

ROWS = [
    ("lambert", "lambert", {}),
    ("phong", "phong", {}),
    ("microfacet", "microfacet", {}),
    ("microfacet ggx/smith conductor", "microfacet",
     {"distribution": "trowbridge_reitz", "shadowing": "smith", "fresnel": "conductor"}),
    ("microfacet blinn/smith", "microfacet", {"distribution": "blinn", "shadowing": "smith"}),
    ("microfacet gaussian/smith conductor", "microfacet",
     {"distribution": "gaussian", "shadowing": "smith", "fresnel": "conductor"}),
    ("ward", "ward", {}),
    ("cook_torrance", "cook_torrance", {}),
]


def _seconds(api, model, params):
    """(seconds to add the node, native nodes, parts); the group removed."""
    import bpy

    from addon import groups
    from verification import harness as common
    mat = common.empty_material("rm_bench_build")[0]
    t0 = time.perf_counter()
    node = api.add_model(mat, model, **params)
    seconds = time.perf_counter() - t0
    tree = node.node_tree
    n_parts = len(groups._parts(tree))
    count = int(tree["rm_native_nodes"])
    bpy.data.materials.remove(mat)
    groups.remove_group(tree)
    return seconds, count, n_parts


def main(argv=None):
    from verification.harness import session as bpy_env
    bpy_env.prepare()
    import bpy

    from addon import api
    from addon.backends.native import build as native_build
    _seconds(api, "lambert", {})  # the extension's one-time costs (imports, fitted data)
    parts_size = native_build.PART_SIZE
    print(f"\nTime to add a node of a variant not yet in the file (api.add_model), native "
          f"nodes built in parts of {parts_size} and in one tree")
    print(f"{'':36s} {'nodes':>6s} {'parts':>6s} {'in parts':>9s} {'one tree':>9s}")
    for label, model, params in ROWS:
        native_build.PART_SIZE = parts_size
        s_parts, count, n_parts = _seconds(api, model, params)
        native_build.PART_SIZE = 10 ** 9
        s_whole, _count, _n = _seconds(api, model, params)
        print(f"{label:36.36s} {count:6d} {n_parts:6d} {s_parts:8.2f}s {s_whole:8.2f}s")
    native_build.PART_SIZE = parts_size
    print(f"(bpy {'.'.join(map(str, bpy.app.version))}; measured, not asserted)")
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
