# SPDX-License-Identifier: GPL-3.0-or-later
"""Instructions per rendered frame of each model, relative to the native Glossy BSDF.

``make bench`` prints this table after the render-time one
(``python -m tools.bench --count`` alone).  Needs valgrind.

Why: render time on a shared 2-core machine moves by up to 1.7x from one
minute to the next, so the time ratios of ``verification.bench.render`` carry about
+-0.15.  valgrind's callgrind counts the instructions the process executes,
and the same render gives the same count whatever else the machine does
(the native frame counted 297.8 M instructions in two processes, equal to
within 1e-5; the table prints that spread).  A count is not a time: instructions
differ in cost, and cache misses are not counted.  But the ratio says what a
material adds to a render at equal samples, and it is repeatable, so a change
of 1 % is visible.

How: the rows of ``verification.bench.render.ROWS`` are dealt to ``jobs`` processes,
each running Python under ``valgrind --tool=callgrind --dump-before=os_getppid``.
A process renders the bench scene (``verification/scenes/bench.py``; 64x64, 8
samples, one render thread so the work is the same every time) for the native
Glossy BSDF in SVM and then for each of its materials, two frames each with
persistent data (the first compiles the shaders).  The render handlers call
``os.getppid()`` before and after every frame, so callgrind writes the
instructions since the previous call to a file: the file written after the
second frame holds that frame's render alone.  The fixed cost of a frame
(film, output file, sync) measured 2.5 M of 298 M instructions for the native
material (a 16-sample frame counts 593 M), so the ratio is the shading's.

``os_getppid`` is the C function behind ``os.getppid`` in CPython; callgrind
finds it in the interpreter's symbol table.  If the interpreter has none
(stripped), callgrind writes no dump: the command says so and exits 1.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parents[2]
BASELINE = "native Glossy GGX, SVM"
MARK_FUNCTION = "os_getppid"


def render_marked(api, rows, marks_path, *, resolution=64, samples=8, frames=2):
    """Render the baseline, then each material of ``rows`` (``bench_render.ROWS``
    entries), ``frames`` frames each, one thread; before and after every frame,
    append ``[label, mode, frame, "pre" | "post"]`` to ``marks_path`` (JSON
    lines) and call ``os.getppid()`` (callgrind's dump trigger)."""
    import bpy

    from verification.scenes import bench as bench_scene
    from verification.suites import verify
    from verification.bench import render as bench_render

    current = {}
    log = open(marks_path, "w", encoding="utf-8")

    def mark(scene, *_args, when):
        log.write(json.dumps([current["label"], current["mode"], scene.frame_current, when]) + "\n")
        log.flush()
        os.getppid()

    def pre(scene, *args):
        mark(scene, *args, when="pre")

    def post(scene, *args):
        mark(scene, *args, when="post")

    plan = [(BASELINE, "path_traced", verify.native_glossy_material("count native", "GGX", 0.5),
             False)]
    for label, model, params in rows:
        for osl in ((True, False) if model is not None else (True,)):
            name = label + ("" if osl else bench_render.NATIVE)
            for mode, mat, _node in bench_render._materials(api, name, model, params):
                plan.append((name, mode, mat, osl))
    scenes = []
    bpy.app.handlers.render_pre.append(pre)
    bpy.app.handlers.render_post.append(post)
    try:
        with tempfile.TemporaryDirectory(prefix="rm_count_") as out_dir:
            for i, (label, mode, mat, osl) in enumerate(plan):
                scene = bench_scene.build_bench_scene(
                    mat, resolution=resolution, samples=samples, frames=frames, osl=osl,
                    name=f"count{i}", threads=1)
                scenes.append(SimpleNamespace(scene=scene))
                scene.render.filepath = os.path.join(out_dir, scene.name + "_")
                current.update(label=label, mode=mode)
                with verify.quiet():
                    bpy.ops.render.render(animation=True, scene=scene.name)
                print(f"  counted {label} ({mode})", flush=True)
    finally:
        bpy.app.handlers.render_pre.remove(pre)
        bpy.app.handlers.render_post.remove(post)
        log.close()
        for holder in scenes:
            verify.dispose(holder)
        for _label, _mode, mat, _osl in plan:
            bench_render.remove_material(mat)


def _summary(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith(("summary:", "totals:")):
                return int(line.split()[1])
    raise RuntimeError(f"no instruction total in {path}")


def frame_counts(marks_path, dump_prefix):
    """``{(label, mode): instructions of the last frame}`` from the marks log and
    callgrind's dumps ``<dump_prefix>.1``, ``.2``, ...: dump k is written at the
    k-th mark and holds the instructions since the previous one."""
    with open(marks_path, encoding="utf-8") as f:
        marks = [json.loads(line) for line in f if line.strip()]
    numbered = {}
    for path in glob.glob(glob.escape(dump_prefix) + ".*"):
        suffix = path.rsplit(".", 1)[1]
        if suffix.isdigit():
            numbered[int(suffix)] = path
    dumps = [numbered[k] for k in sorted(numbered)]
    if not dumps:
        raise RuntimeError(f"callgrind wrote no dump: it did not find {MARK_FUNCTION} in this "
                           f"Python ({sys.executable}), which may be stripped of symbols")
    if len(dumps) != len(marks):
        raise RuntimeError(f"{len(marks)} marks but {len(dumps)} callgrind dumps: something "
                           f"else called {MARK_FUNCTION}")
    counts = {}
    for (label, mode, _frame, when), path in zip(marks, dumps):
        if when == "post":  # in order, so the last frame's count stays
            counts[(label, mode)] = _summary(path)
    return counts


def count(rows=None, *, resolution=64, samples=8, jobs=2, valgrind="valgrind"):
    """``{(label, mode): instructions of one frame}`` for the baseline and every
    material of ``rows`` (default ``bench_render.ROWS``), and the baseline as
    counted in each process (the table prints their spread).  Runs ``jobs``
    processes."""
    from verification.bench import render as bench_render

    rows = bench_render.ROWS if rows is None else rows
    exe = shutil.which(valgrind)
    if exe is None:
        raise RuntimeError(f"{valgrind} is not installed")
    parts = [rows[j::jobs] for j in range(jobs) if rows[j::jobs]]
    with tempfile.TemporaryDirectory(prefix="rm_count_") as tmp:
        procs = []
        for j, part in enumerate(parts):
            rows_file = os.path.join(tmp, f"job{j}.rows.json")
            with open(rows_file, "w", encoding="utf-8") as f:
                json.dump(part, f)
            prefix = os.path.join(tmp, f"job{j}")
            cmd = [exe, "--tool=callgrind", f"--dump-before={MARK_FUNCTION}", "--dump-instr=no",
                   "--dump-line=no", f"--callgrind-out-file={prefix}.cg", f"--log-file={prefix}.vg",
                   sys.executable, "-m", "verification.bench.count", "--inner", rows_file,
                   "--marks", prefix + ".marks", "--resolution", str(resolution),
                   "--samples", str(samples)]
            with open(prefix + ".err", "w", encoding="utf-8") as err:  # Blender's start-up log
                procs.append((subprocess.Popen(cmd, cwd=ROOT, stderr=err), prefix))
        counts, baselines = {}, []
        for proc, prefix in procs:
            if proc.wait() != 0:
                tail = ""
                for log in (prefix + ".err", prefix + ".vg"):
                    with open(log, encoding="utf-8", errors="replace") as f:
                        tail += "".join(f.readlines()[-10:])
                raise RuntimeError(f"counting process failed (exit {proc.returncode}):\n{tail}")
            got = frame_counts(prefix + ".marks", prefix + ".cg")
            baselines.append(got[(BASELINE, "path_traced")])
            counts.update(got)
    return counts, baselines


def print_table(counts, baselines, *, resolution, samples):
    from verification.bench import render as bench_render

    base = baselines[0]
    print(f"\nInstructions per frame relative to the native Glossy BSDF (GGX, roughness 0.5, "
          f"SVM): callgrind, {resolution}x{resolution}, {samples} spp, one render thread; "
          f"the native frame counted {base:,} instructions "
          f"(spread over {len(baselines)} processes: "
          f"{(max(baselines) - min(baselines)) / base:.1e} of it)")
    ex = bench_render.TARGET_EXACT
    print(f"{'':38s} {'path traced':>11s} {'<=':>6s}  "
          f"{'exact + shadow ray':>18s} {'<=' + format(ex, 'g'):>6s}")
    labels = [name for label, model, _params in bench_render.ROWS
              for name in ((label, label + bench_render.NATIVE) if model else (label,))
              if any((name, mode) in counts for mode in bench_render.MODES)]
    for label in labels:
        cells = []
        pt = bench_render.path_traced_target(label)
        for mode, target, width in (("path_traced", pt, 11), ("exact", ex, 18)):
            n = counts.get((label, mode))
            if n is None:
                cells.append(f"{'':>{width}s} {'':>6s}")
            else:
                ratio = n / base
                mark = f"{'yes' if ratio <= target else 'NO'}/{target:g}"
                cells.append(f"{ratio:{width}.3f} {mark:>6s}")
        print(f"{label:38.38s} {cells[0]}  {cells[1]}")
    print("A count is not a time (it weighs every instruction alike and counts no cache "
          "miss), but it repeats: see the spread of the baseline above.")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m verification.bench.count",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--jobs", type=int, default=2, help="processes under valgrind")
    parser.add_argument("--rows", nargs="+", metavar="LABEL",
                        help="only these rows of verification.bench.render.ROWS (default: all)")
    parser.add_argument("--inner", metavar="ROWS_JSON", help=argparse.SUPPRESS)
    parser.add_argument("--marks", help=argparse.SUPPRESS)
    args = parser.parse_args(argv if argv is not None else [])
    if args.inner:  # one counting process, run under callgrind by count()
        from verification.harness import session as bpy_env

        bpy_env.prepare()
        from addon import api

        with open(args.inner, encoding="utf-8") as f:
            rows = [tuple(row) for row in json.load(f)]
        render_marked(api, rows, args.marks, resolution=args.resolution, samples=args.samples)
        return 0
    if shutil.which("valgrind") is None:
        print("\n(instruction counts skipped: valgrind is not installed)")
        return 0
    print(f"\nCounting instructions under valgrind in {args.jobs} processes "
          "(6 to 10 minutes on 2 cores) ...", flush=True)
    from verification.bench import render as bench_render

    rows = None
    if args.rows:
        labels = [label for label, _model, _params in bench_render.ROWS]
        unknown = sorted(set(args.rows) - set(labels))
        if unknown:
            parser.error(f"unknown rows {unknown}; allowed: {labels}")
        rows = [row for row in bench_render.ROWS if row[0] in args.rows]
    try:
        counts, baselines = count(rows, resolution=args.resolution, samples=args.samples,
                                  jobs=args.jobs)
    except RuntimeError as exc:
        print(f"instruction counts failed: {exc}")
        return 1
    print_table(counts, baselines, resolution=args.resolution, samples=args.samples)
    return 0


if __name__ == "__main__":
    from verification.harness import session as bpy_env

    bpy_env.exit_process(main(sys.argv[1:]))
