# SPDX-License-Identifier: GPL-3.0-or-later
"""Render cost of each model relative to Blender's native Glossy BSDF.

``make bench`` (through tools.bench) or ``python -m tools.bench_render``.
Every model (at its defaults; the presets too) is rendered on the same
gonioreflectometer scene as a native Glossy BSDF (GGX, roughness 0.5), at
equal samples (default 256x256, 32 spp, direct light only, all CPU
threads), in path-traced mode (its BSDF output) and in exact mode (its
Direct output with the shadow ray on).  Each time is the best of
``--repeats`` render calls (default 2) after a warm-up render (OSL compiles
its shaders on the first), in CPU time of the process (every render
thread): other jobs on a shared machine disturb it less than wall time.
The native render is re-timed beside every model, so a ratio compares
renders made under the same load; the load average is printed.  Targets:
path traced <= 1.15x, exact <= 0.7x the native Glossy.  Measures and
prints; asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

TARGET_PATH_TRACED = 1.15
TARGET_EXACT = 0.7
LIGHT = (0.35, 0.25, 0.90)


def _scene(mat, *, resolution, samples, api=None, node=None):
    from test_scenes import gonio, verify

    if node is not None:
        verify.set_sun(node, gonio.normalize(LIGHT), 1.0)
    g = gonio.build_gonio_scene(mat, light_dir=LIGHT, resolution=resolution, name="bench")
    g.scene.cycles.samples = int(samples)
    if api is not None:
        api.enable_osl(g.scene)
    return g


def _best(g, repeats, warm_up=True):
    from test_scenes import verify

    times = []
    with verify.quiet():
        for _ in range(repeats + int(warm_up)):  # a first render compiles / warms up
            c0 = time.process_time()
            g.render()
            times.append(time.process_time() - c0)
    return min(times[int(warm_up):])


def bench(api, *, resolution=256, samples=32, repeats=2, models=None):
    """Per model: ``{"model", "native", "path_traced", "exact"}`` seconds.
    The native Glossy is re-timed beside every model, so that a ratio
    compares renders made under the same machine load."""
    from addon import catalogue
    from test_scenes import verify

    native = verify.native_glossy_material("bench_native", "GGX", 0.5)
    g_native = _scene(native, resolution=resolution, samples=samples)
    _best(g_native, 1)
    rows = []
    try:
        # the same native node with the OSL shading system on: the cost of OSL itself
        g_osl = _scene(native, resolution=resolution, samples=samples, api=api)
        try:
            row = {"model": "(native Glossy, OSL on)"}
            row["path_traced"] = _best(g_osl, repeats)
            row["exact"] = float("nan")
        finally:
            verify.dispose(g_osl)
        row["native"] = _best(g_native, repeats, warm_up=False)
        rows.append(row)
        for model in models or (*catalogue.MODELS, *catalogue.PRESETS):
            row = {"model": model}
            for mode in ("path_traced", "exact"):
                mat = verify.new_material(f"bench_{model}_{mode}")
                node = api.add_model(mat, model, mode=mode)
                g = _scene(mat, resolution=resolution, samples=samples, api=api,
                           node=node if mode == "exact" else None)
                try:
                    row[mode] = _best(g, repeats)
                finally:
                    verify.dispose(g)
                    verify.remove_material(mat)
            row["native"] = _best(g_native, repeats, warm_up=False)
            rows.append(row)
    finally:
        verify.dispose(g_native)
        verify.remove_material(native)
    return rows


def print_table(rows, resolution, samples):
    native_ms = ", ".join(f"{r['native'] * 1000:.0f}" for r in rows)
    print(f"\nRender time relative to the native Glossy BSDF (GGX r=0.5, re-timed beside each "
          f"model: {native_ms} ms CPU), {resolution}x{resolution}, {samples} spp, gonio scene, "
          f"direct light, {os.cpu_count()} CPU threads")
    print(f"{'model':24s} {'path traced':>12s} {'ratio':>6s} {'<=' + format(TARGET_PATH_TRACED, 'g'):>6s}"
          f"  {'exact+shadow':>12s} {'ratio':>6s} {'<=' + format(TARGET_EXACT, 'g'):>6s}")
    for r in rows:
        pt, ex = r["path_traced"] / r["native"], r["exact"] / r["native"]
        line = (f"{r['model']:24.24s} {r['path_traced'] * 1000:10.0f}ms {pt:6.2f} "
                f"{'yes' if pt <= TARGET_PATH_TRACED else 'NO':>6s}  ")
        if ex == ex:  # not NaN
            line += (f"{r['exact'] * 1000:10.0f}ms {ex:6.2f} "
                     f"{'yes' if ex <= TARGET_EXACT else 'NO':>6s}")
        print(line)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m tools.bench_render",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--samples", type=int, default=32)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--installed", action="store_true",
                        help="build, install and use the extension zip instead of the repo's addon.api")
    args = parser.parse_args(argv if argv is not None else [])
    from tools import bpy_env

    bpy = bpy_env.prepare()
    if args.installed:
        import importlib

        from tools.build_zip import build_zip
        api = importlib.import_module(bpy_env.install_extension(build_zip()) + ".api")
    else:
        from addon import api
    rows = bench(api, resolution=args.resolution, samples=args.samples, repeats=args.repeats)
    print_table(rows, args.resolution, args.samples)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"(Blender {bpy.app.version_string}; load average {load} on {os.cpu_count()} CPUs; "
          "measured, not asserted)")
    return 0


if __name__ == "__main__":
    status = main(sys.argv[1:])
    from tools import bpy_env
    sys.stdout.flush()
    bpy_env.cleanup()
    os._exit(status)
