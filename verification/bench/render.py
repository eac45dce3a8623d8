# SPDX-License-Identifier: GPL-3.0-or-later
"""Render cost of each model relative to Blender's native Glossy BSDF.

``make bench`` (through tools.bench) or ``python -m verification.bench.render``.

Scene (verification/scenes/bench.py): a sphere filling the frame, so every pixel
shades the material under test; a sun; direct light only; default 128x128,
16 samples, all CPU threads.  Each material renders ``--frames`` frames as
one animation with persistent data: the first frame also builds the scene
and compiles the shaders (for OSL, its runtime optimisation and JIT), the
later ones only render.  The ratio compares the later frames, in CPU time of
the process (every render thread); the one-time set-up (first frame minus a
later one) is printed beside it.

Baseline: Blender's native Glossy BSDF (GGX, roughness 0.5) in Cycles'
default shading system (SVM), at equal samples.  Each model is timed in
path-traced mode (its BSDF output) and in exact mode (its Direct output,
shadow ray on), right after a native render; ``--rounds`` rounds of this,
and the ratio printed is the median over rounds with its range: on a shared
2-core machine the same render's time moves by up to 1.7x from one minute to
the next, and a ratio of renders made seconds apart cancels most of that.

The first rows are floors, not models: Blender's own Glossy BSDF with the
OSL shading system on (the cost of OSL itself, which a path-traced OSL
material cannot go below; the third with an anisotropic lobe on the UV
tangent), and the closures that Ward, Torrance-Sparrow, Cook-Torrance and
Kajiya-Kay build, alone in a one-line OSL shader.  Targets for the OSL
shaders: path traced <= 1.15x, exact <= 0.7x.  Every model row is measured
twice: with OSL (its OSL shaders) and with OSL off (its native nodes, in the
kernel code of the GPU devices; targets: path traced <= 1.2x, fitted
mixtures <= 1.3x, exact <= 0.7x).  Measures and prints; asserts nothing.
The same ratios in instructions, which repeat where time does not:
verification/bench/count.py.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile

TARGET_PATH_TRACED = 1.15
TARGET_PATH_TRACED_NATIVE = 1.2
TARGET_MIXTURE = 1.3   # a fitted mixture of closures (issue: the path-traced output is the model)
TARGET_EXACT = 0.7
NATIVE = " [native]"   # the label suffix of a row measured with OSL off

# The closures some models build, alone in a one-line OSL shader, at the
# models' default widths (what the model's own code adds is the difference);
# ``tangent`` is the UV tangent, linked only where a shader uses it (an
# isotropic lobe takes dPdu).
CLOSURE_FLOORS = {
    # Torrance-Sparrow, Cook-Torrance: beta 10 deg is alpha 0.21 in Beckmann
    "dielectric": 'BSDF = dielectric_bsdf(N, normalize(dPdu), color(1.0), color(0.0), '
                  '0.21, 0.21, 1.5, "beckmann");',
    # Ward: alpha_x 0.3, alpha_y 0.08
    "beckmann-aniso": 'BSDF = microfacet("beckmann", N, normalize(tangent), 0.3, 0.08, 0.0, 0);',
    # Kajiya-Kay: exponent 40 is the hair lobe's latitudinal roughness
    # 0.38 sqrt(2 / 42), its azimuthal one 1, and the GGX lobe's roughness
    # 0.7 sqrt(2 / 42) along the fibre, 1 across it (KajiyaKay.closure)
    "diffuse+hair+ggx": "BSDF = 0.5 * diffuse(N) + hair_reflection(N, 0.0829, 1.0, "
                        "normalize(tangent), 0.0) + 0.2 * microfacet(\"ggx\", N, "
                        "normalize(tangent), 0.1528, 1.0, 0.0, 0);",
}

# (label, model or None for a floor row, params; for a floor row, the native
# Glossy distribution [+ " anisotropic"], or "closure <CLOSURE_FLOORS key>")
ROWS = [
    ("native Glossy GGX, OSL", None, "GGX"),
    ("native Glossy Beckmann, OSL", None, "BECKMANN"),
    ("native aniso Beckmann+UV tangent, OSL", None, "BECKMANN anisotropic"),
    ("aniso Beckmann alone+UV tangent, OSL", None, "closure beckmann-aniso"),
    ("dielectric_bsdf alone, OSL", None, "closure dielectric"),
    ("diffuse+hair_reflection+GGX alone, OSL", None, "closure diffuse+hair+ggx"),
    ("lambert", "lambert", {}),
    ("phong", "phong", {}),
    ("blinn_phong", "blinn_phong", {}),
    ("microfacet", "microfacet", {}),
    ("microfacet gaussian/smith", "microfacet", {"distribution": "gaussian", "shadowing": "smith"}),
    ("kajiya_kay", "kajiya_kay", {}),
    ("ward", "ward", {}),
    ("torrance_sparrow", "torrance_sparrow", {}),
    ("cook_torrance", "cook_torrance", {}),
]
MODES = ("path_traced", "exact")


def _median_range(values):
    return statistics.median(values), min(values), max(values)


def _time(scene, out_dir):
    """``(CPU seconds of the frames after the first, the first frame's extra)``
    of rendering ``scene``'s animation: rendering, and the one-time set-up."""
    from verification.scenes import bench as bench_scene
    from verification.suites import verify

    with verify.quiet():
        frames = bench_scene.frame_cpu_seconds(scene, out_dir)
    later = frames[1:]
    return sum(later), frames[0] - statistics.median(later)


def _closure_material(name, floor):
    """A material whose surface is one of :data:`CLOSURE_FLOORS`, in a Script
    node (its ``tangent`` input linked to the UV tangent if it uses it)."""
    from addon.backends.osl import compile as oslutil
    from verification import harness as common

    bpy = common.import_bpy()
    mat, tree, out = common.empty_material(name)
    text = bpy.data.texts.new(name + ".osl")
    text.write('#include "stdcycles.h"\n'
               "shader closure_floor(vector tangent = vector(1.0, 0.0, 0.0),\n"
               "                     output closure color BSDF = 0)\n"
               "{\n    " + CLOSURE_FLOORS[floor] + "\n}\n")
    script = tree.nodes.new("ShaderNodeScript")
    script.mode = 'INTERNAL'
    script.script = text
    oslutil.compile_script_node(script)
    if "tangent" in CLOSURE_FLOORS[floor]:  # Cycles looks the UV tangent up once it is linked
        tangent = tree.nodes.new("ShaderNodeTangent")
        tangent.direction_type = "UV_MAP"
        tree.links.new(tangent.outputs["Tangent"], script.inputs["tangent"])
    tree.links.new(script.outputs["BSDF"], out.inputs["Surface"])
    return mat


def remove_material(mat):
    """Remove a benchmark material, with the shader text of a floor row."""
    from verification import harness as common
    from verification.suites import verify

    bpy = common.import_bpy()
    texts = [node.script for node in mat.node_tree.nodes
             if node.bl_idname == "ShaderNodeScript" and node.script is not None
             and node.script.name == mat.name + ".osl"]
    verify.remove_material(mat)
    for text in texts:
        bpy.data.texts.remove(text)


def _materials(api, label, model, params):
    """``[(mode, material, node or None)]`` for one row; an exact-mode node's
    light is the bench scene's sun."""
    from verification.scenes import bench as bench_scene
    from verification import harness as common
    from verification.suites import verify

    if model is None and params.startswith("closure "):
        return [("path_traced", _closure_material(f"bench {label}", params.split()[1]), None)]
    if model is None:
        distribution, *aniso = params.split()
        mat = verify.native_glossy_material(f"bench {label}", distribution, 0.5)
        if aniso:  # what Ward and Kajiya-Kay also pay: an anisotropic lobe on the UV tangent
            tree = mat.node_tree
            glossy = next(n for n in tree.nodes if "Anisotropy" in n.inputs)
            glossy.inputs["Anisotropy"].default_value = 0.8
            tangent = tree.nodes.new("ShaderNodeTangent")
            tangent.direction_type = "UV_MAP"
            tree.links.new(tangent.outputs["Tangent"], glossy.inputs["Tangent"])
        return [("path_traced", mat, None)]
    out = []
    for mode in MODES:
        mat = verify.new_material(f"bench {label} {mode}")
        node = api.add_model(mat, model, mode=mode, **params)
        if mode == "exact":
            verify.set_sun(node, common.normalize(bench_scene.LIGHT), 1.0)
        out.append((mode, mat, node))
    return out


def bench(api, *, resolution=128, samples=16, frames=4, rounds=5, rows=None):
    """Per row: ``{"label", mode: {"ratio": (median, min, max), "setup": s}}``
    with the ratio to the native Glossy BSDF rendered just before it."""
    from types import SimpleNamespace

    from verification.scenes import bench as bench_scene
    from verification.suites import verify

    if frames < 2:
        raise ValueError("frames must be at least 2 (the first one compiles)")
    rows = ROWS if rows is None else rows
    made = []  # (holder of the scene, material) to dispose of

    def scene(mat, *, osl):
        sc = bench_scene.build_bench_scene(mat, resolution=resolution, samples=samples,
                                           frames=frames, osl=osl, name=f"bench{len(made)}")
        made.append((SimpleNamespace(scene=sc), mat))
        return sc

    try:
        native = scene(verify.native_glossy_material("bench native", "GGX", 0.5), osl=False)
        plan = []
        for label, model, params in rows:
            for osl in ((True, False) if model is not None else (True,)):
                name = label + ("" if osl else NATIVE)
                plan.append((name, {mode: scene(mat, osl=osl)
                                    for mode, mat, _node in _materials(api, name, model, params)}))
        measured = {label: {mode: ([], []) for mode in scenes} for label, scenes in plan}
        with tempfile.TemporaryDirectory(prefix="rm_bench_") as out_dir:
            _time(native, out_dir)  # warm-up: the session's first render also loads Cycles' kernels
            for r in range(rounds):
                for label, scenes in plan:
                    base, _setup = _time(native, out_dir)
                    for mode, sc in scenes.items():
                        t, setup = _time(sc, out_dir)
                        measured[label][mode][0].append(t / base)
                        measured[label][mode][1].append(setup)
                print(f"  round {r + 1}/{rounds} done", flush=True)
    finally:
        for holder, mat in made:
            verify.dispose(holder)
            remove_material(mat)
    results = []
    for label, per_mode in measured.items():
        row = {"label": label}
        for mode, (ratios, setups) in per_mode.items():
            row[mode] = {"ratio": _median_range(ratios), "setup": statistics.median(setups)}
        results.append(row)
    return results


def path_traced_target(label):
    """The path-traced target of a row: OSL 1.15x; native nodes 1.2x, a
    fitted mixture 1.3x."""
    if not label.endswith(NATIVE):
        return TARGET_PATH_TRACED
    return TARGET_MIXTURE if _is_mixture(label[:-len(NATIVE)]) else TARGET_PATH_TRACED_NATIVE


def _is_mixture(label):
    from addon.core.formulas import models as formulas

    row = next((r for r in ROWS if r[0] == label), None)
    if row is None or row[1] is None:
        return False
    from addon.core import catalogue, variants
    model, _fixed, _defaults = catalogue.resolve(row[1])
    _m, variant = variants.resolve_variant(row[1], {k: v for k, v in row[2].items()
                                                    if k in ("distribution", "shadowing",
                                                             "fresnel", "normalization")})
    status = formulas.FORMULAS[model.id].fidelity(variant, formulas.NATIVE_CLOSURES)
    return status in ("fitted", "approx") and model.id in ("microfacet", "phong", "blinn_phong")


def _cell(entry, target):
    if entry is None:
        return f"{'':>19s} {'':>5s} {'':>7s}"
    med, lo, hi = entry["ratio"]
    ok = "yes" if med <= target else "NO"
    return (f"{med:5.2f} [{lo:4.2f}-{hi:4.2f}] {ok:>5s} {entry['setup'] * 1000:5.0f}ms")


def print_table(results, *, resolution, samples, frames, rounds):
    print(f"\nRender time relative to the native Glossy BSDF (GGX, roughness 0.5, SVM), "
          f"median [range] of {rounds} rounds; {resolution}x{resolution}, {samples} spp, "
          f"frames 2-{frames} of an animation with persistent data; CPU time of all "
          f"{os.cpu_count()} threads; set-up = first frame's extra (scene build, shader compile)")
    print(f"{'':38s} {'path traced':^19s} {'<=':>5s} "
          f"{'set-up':>7s}  {'exact + shadow ray':^19s} {'<=' + format(TARGET_EXACT, 'g'):>5s} "
          f"{'set-up':>7s}")
    for row in results:
        target = path_traced_target(row["label"])
        print(f"{row['label']:38.38s} {_cell(row.get('path_traced'), target)}  "
              f"{_cell(row.get('exact'), TARGET_EXACT)}")
    print("The floor rows are what a path-traced OSL material cannot go below: Blender's "
          "Glossy node under OSL, or the model's closure with nothing around it.  Targets: "
          f"path traced <= {TARGET_PATH_TRACED:g}x with OSL; rows "
          f"marked{NATIVE} render the native nodes (OSL off): path traced <= "
          f"{TARGET_PATH_TRACED_NATIVE:g}x, a fitted mixture <= {TARGET_MIXTURE:g}x.")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m verification.bench.render",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--frames", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--installed", action="store_true",
                        help="build, install and use the extension zip instead of the repo's addon.api")
    args = parser.parse_args(argv if argv is not None else [])
    from verification.harness import session as bpy_env

    bpy = bpy_env.prepare()
    if args.installed:
        import importlib

        from verification.harness.package import build_zip
        api = importlib.import_module(bpy_env.install_extension(build_zip()) + ".api")
    else:
        from addon import api
    results = bench(api, resolution=args.resolution, samples=args.samples, frames=args.frames,
                    rounds=args.rounds)
    print_table(results, resolution=args.resolution, samples=args.samples, frames=args.frames,
                rounds=args.rounds)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"(Blender {bpy.app.version_string}; load average {load} on {os.cpu_count()} CPUs; "
          "measured, not asserted)")
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
