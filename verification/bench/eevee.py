# SPDX-License-Identifier: GPL-3.0-or-later
"""EEVEE shader compile time per model, the peak memory of a process that
renders each model (EEVEE, Cycles with OSL off and on), and the native node
count per model.

Compile time: EEVEE compiles a material's GPU shaders the first time it
renders it.  For each model (native nodes: EEVEE runs no OSL), in
path-traced and exact mode, a fresh material on the bench scene's sphere
renders six frames; the first frame's extra time (first minus the
median of the others) is the compile, where it exceeds the others'
spread (their slowest left out).  The baseline is a Principled BSDF material measured the same way
(three samples, each with one input fed by a Value node, so that each is
new code).  Target: <= 3x.

Every measurement runs in its own process, after an Emission material
has loaded EEVEE and compiled the engine's own shaders, because a
process remembers: Blender reuses the compiled shader of any material
whose generated code it has seen (a second plain Principled material
compiled nothing measurable), and EEVEE compiles its lighting shaders
for a closure type the first time a material uses it (about half a
second here, for the Principled material as for the path-traced
mixtures).  So the time is what the first such material of a new scene
costs, engine shaders for its closures included.

On this machine EEVEE runs on Mesa's software rasteriser (llvmpipe),
whose compile times stand for a GPU driver's only roughly.  Mesa keeps
compiled shaders in a disk cache across processes
(~/.cache/mesa_shader_cache): a material compiled by an earlier run would
cost nothing here, so the cache is switched off (MESA_SHADER_CACHE_DISABLE,
unless the caller set it).  Measures and prints; asserts nothing.

Memory: the peak resident size of each of these processes at its end
(getrusage; the Principled baseline's the median of its three), and of
the same measurement in Cycles, with OSL off (SVM, the kernel code of the
GPU devices) and on, in processes of their own.
Before the measured material, every module of the extension (its fitted
data among them) is imported and a material of another model is made
(kept, on no object), so that a process's one-time costs are in the
baseline's peak too.  No issue sets a memory target: the table is printed
to be watched, beside the Principled baseline's.

Node count: the native nodes each variant's group holds (the plan of
addon/backends/native/emit.py, without Blender), per model at its defaults.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

TARGET_COMPILE = 3.0

ROWS = [
    ("lambert", "lambert", {}),
    ("phong", "phong", {}),
    ("blinn_phong", "blinn_phong", {}),
    ("microfacet", "microfacet", {}),
    ("microfacet gaussian/smith", "microfacet", {"distribution": "gaussian",
                                                 "shadowing": "smith"}),
    ("microfacet ggx/smith_correlated", "microfacet", {"distribution": "trowbridge_reitz",
                                                       "shadowing": "smith_correlated"}),
    ("kajiya_kay", "kajiya_kay", {}),
    ("ward", "ward", {}),
    ("torrance_sparrow", "torrance_sparrow", {}),
    ("cook_torrance", "cook_torrance", {}),
]


def node_counts(rows=ROWS) -> list:
    """``[(label, nodes of the exact graph + closures)]`` from the plans."""
    from addon.backends.native import emit
    from addon.core import catalogue, variants
    from addon.core.formulas import models as formulas

    out = []
    for label, model_name, params in rows:
        model, _fixed, _defaults = catalogue.resolve(model_name)
        enums = {k: v for k, v in params.items() if k in
                 {p.name for p in variants.variant_params(model_name)}}
        _m, variant = variants.resolve_variant(model_name, enums)
        variant = {k: v for k, v in variant.items() if k != "backend"}
        v = formulas.Values(model.id, variant, known=True)
        s = formulas.shading(model.id, variant, caps=formulas.NATIVE_CLOSURES)
        exact = formulas.exact(model.id, v, s)
        bsdf = formulas.FORMULAS[model.id].closure(v, s)
        out.append((label, emit.count({"BSDF": bsdf}), emit.count(exact),
                    emit.count({"BSDF": bsdf, **exact})))
    return out


def _principled(name, linked=None):
    """A Principled BSDF material; ``linked``: an input fed by a Value node,
    which changes the generated shader (Blender reuses a compiled shader for
    any material whose generated code is the same, so a second plain
    Principled material compiles nothing)."""
    from verification import harness as common

    mat, tree, out = common.empty_material(name)
    node = tree.nodes.new("ShaderNodeBsdfPrincipled")
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    if linked is not None:
        value = tree.nodes.new("ShaderNodeValue")
        value.outputs[0].default_value = node.inputs[linked].default_value
        tree.links.new(value.outputs[0], node.inputs[linked])
    return mat


def _emission(name):
    """The warm-up material: it loads EEVEE and compiles the engine's own
    shaders, and shares no generated code with the Principled baseline."""
    from verification import harness as common

    mat, tree, out = common.empty_material(name)
    node = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


BASELINE_LINKS = ("Roughness", "Metallic", "IOR")  # one baseline sample each


STEADY_FRAMES = 5  # frames after the first whose median is the render without the compile


ENGINES = ("eevee", "cycles", "cycles-osl")  # "cycles": OSL off (SVM)


def _peak_mb():
    """This process's peak resident size so far, in MB."""
    import resource

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024  # bytes there, KiB here


def _compile_seconds(mat, out_dir, resolution, engine="eevee"):
    """``(seconds, isolated, spread)``: the first frame of a fresh EEVEE scene with
    ``mat`` minus the median of the next STEADY_FRAMES (a single second
    frame is no baseline: a frame can take up to a second longer here), and
    whether that is more than the spread of those frames (else it is noise,
    not a compile).  The spread leaves out the slowest of them: one slow
    frame among frames that compile nothing is a hiccup of the machine (0.27 s
    in one of 4.5's runs), and would hide every compile shorter than it.
    ``engine`` (:data:`ENGINES`) renders the scene: EEVEE for the compile
    table; Cycles with OSL off or on for the memory table only, which keeps
    the process's peak and leaves these numbers unused."""
    from verification import harness as common
    from verification.scenes import bench as bench_scene
    from verification.suites import verify

    frames = 1 + STEADY_FRAMES
    scene = bench_scene.build_bench_scene(mat, resolution=resolution, samples=1, frames=frames,
                                          osl=engine == "cycles-osl", name=f"{engine}_{mat.name}")
    if engine == "eevee":
        common.configure_eevee(scene, samples=1)
    times = []
    try:
        for frame in range(1, frames + 1):
            scene.frame_set(frame)
            t0 = time.perf_counter()
            with verify.quiet():
                common.render_to_exr(scene, os.path.join(out_dir, f"{mat.name}_{frame}.exr"))
            times.append(time.perf_counter() - t0)
    finally:
        from types import SimpleNamespace
        verify.dispose(SimpleNamespace(scene=scene))
    steady = times[1:]
    extra = times[0] - statistics.median(steady)
    fastest = sorted(steady)[:-1]
    spread = max(fastest) - min(fastest)
    return extra, extra > spread, spread


def _material(api, spec):
    """The material of one measurement: ``{"principled": input}`` or
    ``{"model": name, "mode": mode, "params": {...}}`` (JSON: it is passed
    to a fresh process)."""
    from verification.suites import verify

    if "principled" in spec:
        return _principled(f"eevee principled {spec['principled']}", spec["principled"])
    mat = verify.new_material(f"eevee {spec['model']} {spec['mode']}")
    api.add_model(mat, spec["model"], mode=spec["mode"], **spec["params"])
    return mat


def _load_extension(api, model):
    """Import every module of the extension (its fitted data among them)
    and make a material of ``model`` (kept, on no object), so that what
    making the next material adds is that material's own, not the costs
    of a process's first one."""
    import importlib
    import pkgutil

    import addon
    from verification.suites import verify

    for module in pkgutil.walk_packages(addon.__path__, "addon."):
        importlib.import_module(module.name)
    api.add_model(verify.new_material("extension warm-up"), model)


def measure_one(api, spec, *, resolution=32):
    """In this (fresh) process: the engine (``spec["engine"]``, default
    EEVEE) loaded, and EEVEE's own shaders compiled, by an Emission
    material, then ``spec``'s material timed (:func:`_compile_seconds`).
    Returns ``(seconds, isolated, spread, peak)``: the last, the process's
    peak resident size in MB at the end."""
    engine = spec.get("engine", "eevee")
    with tempfile.TemporaryDirectory(prefix="rm_eevee_") as out_dir:
        _compile_seconds(_emission("warm-up"), out_dir, resolution, engine)
        _load_extension(api, "phong" if spec.get("model") == "lambert" else "lambert")
        timing = _compile_seconds(_material(api, spec), out_dir, resolution, engine)
    return (*timing, _peak_mb())


def _run_fresh(spec) -> tuple:
    """:func:`measure_one` in a new Python process: Blender reuses a
    compiled shader for a material whose generated code it has seen, and
    EEVEE compiles the shaders of a closure type the first time any material
    uses it, so every measurement starts from the same state: a fresh
    process, its only earlier material an Emission."""
    out = subprocess.run([sys.executable, "-m", "verification.bench.eevee", "--one",
                          json.dumps(spec)], capture_output=True, text=True, check=False,
                         cwd=ROOT)
    for line in reversed(out.stdout.splitlines()):
        if line.startswith(RESULT):
            return tuple(json.loads(line[len(RESULT):]))
    raise RuntimeError(f"no result from the EEVEE measurement of {spec}:\n"
                       f"{out.stdout[-2000:]}\n{out.stderr[-2000:]}")


def bench(*, rows=ROWS):
    base = [_run_fresh({"principled": name}) for name in BASELINE_LINKS]
    base_s = statistics.median(b[0] for b in base)
    base_isolated = sum(b[1] for b in base) >= 2
    print(f"  Principled baseline: {', '.join(f'{b[0]:.2f} s' for b in base)}", flush=True)
    memory = {("principled", "eevee"): statistics.median(b[3] for b in base)}
    for engine in ENGINES[1:]:
        memory[("principled", engine)] = _run_fresh({"principled": BASELINE_LINKS[0],
                                                     "engine": engine})[3]
    results = []
    for label, model, params in rows:
        row = {"label": label}
        for mode in ("path_traced", "exact"):
            spec = {"model": model, "mode": mode, "params": params}
            seconds, isolated, spread, memory[(label, mode, "eevee")] = _run_fresh(spec)
            for engine in ENGINES[1:]:
                memory[(label, mode, engine)] = _run_fresh({**spec, "engine": engine})[3]
            row[mode + "_s"] = seconds
            # a ratio only where both the material's and the baseline's compile showed;
            # else a bound: a compile hidden in the frames' noise is under it plus their spread
            row[mode] = seconds / base_s if isolated and base_isolated else None
            row[mode + "_bound"] = (max(seconds, 0.0) + spread) / base_s if base_isolated \
                else None
        results.append(row)
        print(f"  {label} done", flush=True)
    return (base_s, base_isolated), results, memory


def print_memory(memory, rows=ROWS):
    """The memory table: each process's peak (:func:`measure_one`) per engine."""
    print("\nPeak resident size of a process that rendered the material, MB (a warm-up, "
          "then a new scene with it, 6 frames at 32x32, one sample), in EEVEE, Cycles with "
          "OSL off and Cycles with OSL; then that less the Principled BSDF baseline's")
    print(f"{'':34s} {'EEVEE':>6s} {'SVM':>6s} {'OSL':>6s}   {'EEVEE':>6s} {'SVM':>6s} {'OSL':>6s}")
    base = [memory[("principled", engine)] for engine in ENGINES]

    def line(label, key):
        peaks = [memory[(*key, engine)] for engine in ENGINES]
        print(f"{label:34.34s} " + " ".join(f"{p:6.0f}" for p in peaks) + "   "
              + " ".join(f"{p - b:+6.0f}" for p, b in zip(peaks, base)))
    line("Principled BSDF (baseline)", ("principled",))
    for label, _model, _params in rows:
        for mode in ("path_traced", "exact"):
            line(f"{label} {'path traced' if mode == 'path_traced' else mode}", (label, mode))


def print_tables(base, results, counts):
    base_s, base_isolated = base
    print(f"\nEEVEE shader compile time relative to a Principled BSDF material "
          f"({base_s:+.2f} s here; software OpenGL), target <= {TARGET_COMPILE:g}x")
    if not base_isolated:
        print("(the Principled material's first frame was not slower than its next ones by "
              "more than their spread: no ratio is a measure)")
    print(f"{'':34s} {'path traced':>18s} {'exact':>18s}")
    for row in results:
        cells = []
        for mode in ("path_traced", "exact"):
            if row[mode] is None:  # no compile seen (here or in the baseline)
                bound, seconds = row[mode + "_bound"], row[mode + "_s"]
                if bound is None:
                    cells.append(f"not isolated ({seconds:+.2f}s)")
                else:
                    ok = "yes" if bound <= TARGET_COMPILE else "NO"
                    cells.append(f"<{bound:4.2f}x {seconds:+5.2f}s {ok:>4s}")
                continue
            ok = "yes" if row[mode] <= TARGET_COMPILE else "NO"
            cells.append(f"{row[mode]:5.2f}x {row[mode + '_s']:5.2f}s {ok:>4s}")
        print(f"{row['label']:34.34s} {cells[0]:>18s} {cells[1]:>18s}")
    if any(row[m] is None for row in results for m in ("path_traced", "exact")):
        print(f"'<': the first frame was not slower than the median of the next "
              f"{STEADY_FRAMES} by more than their spread, so the compile is lost in the "
              "frames' noise: the bound is its extra time (or 0) plus that spread; 'not "
              "isolated': the baseline's compile did not show either, no ratio at all")
    print("\nNative nodes per group (the model at its defaults): the path-traced closures, "
          "the exact evaluation for one light, and the group's total")
    print(f"{'':34s} {'BSDF':>6s} {'exact':>6s} {'total':>6s}")
    for label, bsdf, exact, total in counts:
        print(f"{label:34.34s} {bsdf:6d} {exact:6d} {total:6d}")


RESULT = "EEVEE-COMPILE "


def main(argv=None):
    from verification.harness import session as bpy_env

    argv = list(sys.argv[1:] if argv is None else argv)
    os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")  # before EEVEE's GL context
    if argv[:1] == ["--one"]:
        bpy_env.prepare()
        from addon import api
        print(RESULT + json.dumps(measure_one(api, json.loads(argv[1]))), flush=True)
        return 0
    base, results, memory = bench()
    print_tables(base, results, node_counts())
    print_memory(memory)
    import importlib.metadata
    print(f"(bpy {importlib.metadata.version('bpy')}; measured, not asserted)")
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
