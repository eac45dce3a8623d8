# SPDX-License-Identifier: GPL-3.0-or-later
"""The main command: ``make demo`` (``python -m tools.demo``).

1. Builds the extension zip with Blender's own tool and installs it into a
   clean headless Blender (throwaway user folders, ``tools.bpy_env``).
2. Imports the **installed** extension's public API
   (``bl_ext.<repo>.reflection_models.api``) and runs every verification case
   of ``test_scenes.cases`` in both modes on the virtual gonioreflectometer,
   the native-Glossy oracle checks, the white furnace and the gallery.
3. Prints progress and a summary table; writes ``out/report.html`` (renders,
   references, error heat maps, the gallery, polar plots of every lobe) and
   ``out/report.json``, and copies the gallery to ``docs/gallery.png``.

Exits 1 if any check with a tolerance is out of it.  Options: ``--resolution``
(gonio pixels, default 128), ``--quick`` (one light per case, no gallery).
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import re
import shutil
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
OUT = REPO_ROOT / "out"

# Polar plots: (title, model, params).
POLAR = (
    ("Lambert", "lambert", {}),
    ("Phong s=20", "phong", {"normalization": "energy"}),
    ("Blinn-Phong s=20", "blinn_phong", {"normalization": "energy"}),
    ("Microfacet GGX β=25°", "microfacet", {"distribution": "trowbridge_reitz",
                                           "shadowing": "smith_correlated", "beta": 25 * math.pi / 180}),
    ("Microfacet Beckmann β=25°", "microfacet", {"distribution": "beckmann",
                                               "beta": 25 * math.pi / 180}),
    ("Microfacet Gaussian β=25°", "microfacet", {"distribution": "gaussian",
                                               "beta": 25 * math.pi / 180}),
    ("Microfacet Blinn β=25°", "microfacet", {"distribution": "blinn", "beta": 25 * math.pi / 180}),
    ("Torrance-Sparrow", "torrance_sparrow", {}),
    ("Cook-Torrance", "cook_torrance", {}),
    ("Ward (x: αx)", "ward", {}),
    ("Kajiya-Kay (fibre along x)", "kajiya_kay", {}),
)


def _slug(text):
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")


def log(msg=""):
    print(msg, flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m tools.demo", description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--quick", action="store_true", help="one light per case, no gallery")
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args(argv)
    status = 1
    try:
        status = run(args)
    except BaseException:  # os._exit below would swallow the traceback
        import traceback
        traceback.print_exc()
    finally:
        from tools import bpy_env
        sys.stdout.flush()
        sys.stderr.flush()
        bpy_env.cleanup()
        os._exit(status)  # bpy 4.5 can hang at interpreter exit


def run(args):
    t_start = time.perf_counter()
    out = Path(args.out)
    img_dir = out / "img"
    if img_dir.exists():
        shutil.rmtree(img_dir)
    img_dir.mkdir(parents=True, exist_ok=True)

    from tools import bpy_env
    from tools.build_zip import build_zip

    log("== Reflection Models: verification demo ==")
    zip_path = build_zip()
    log(f"built {zip_path.relative_to(REPO_ROOT)}")
    bpy = bpy_env.prepare()
    module = bpy_env.install_extension(zip_path)
    api = importlib.import_module(module + ".api")
    log(f"installed into a clean Blender {bpy.app.version_string}; using {api.__name__}")

    from test_scenes import cases as cases_mod, gallery, verify
    from tools import report

    version = verify.blender_version()
    res = args.resolution
    light_dirs = cases_mod.LIGHT_DIRS[:1] if args.quick else cases_mod.LIGHT_DIRS
    theta_d = cases_mod.THETA_D_SWEEP[:2] if args.quick else cases_mod.THETA_D_SWEEP
    results = []
    all_cases = cases_mod.CASES
    total = 2 * len(all_cases)
    log(f"\n-- gonioreflectometer: {len(all_cases)} cases x 2 modes, {res}x{res} px, "
        f"{len(light_dirs)} lights (Fresnel: theta_d {', '.join(f'{t:g}' for t in theta_d)} deg)")
    k = 0
    for case in all_cases:
        for mode in ("exact", "path_traced"):
            k += 1
            r = verify.run_case(case, mode, resolution=res, light_dirs=light_dirs,
                                theta_d=theta_d, api=api)
            results.append(r)
            log(f"[{k:3d}/{total}] {case.id:62.62s} {mode:11s} {r['status']:6s} "
                f"max {r['max_rel_error']:.2e}  {report.verdict(r['pass']):8s} "
                f"{r['seconds']:.2f}s")

    log("\n-- independent oracle: exact mode vs Blender's native Glossy BSDF")
    for dist, alpha in (("trowbridge_reitz", 0.3), ("beckmann", 0.3), ("beckmann", 0.8)):
        r = verify.run_oracle(dist, alpha, resolution=res, light_dirs=light_dirs, api=api)
        results.append(r)
        log(f"{r['variant']:70s} max {r['max_rel_error']:.2e} (tol {r['tolerance']:.0e}) "
            f"{report.verdict(r['pass'])}")

    log("\n-- white furnace: path-traced energy-normalised models reflect <= 1")
    for model, params, variant in verify.FURNACE_CASES:
        r = verify.run_furnace(model, params, variant, resolution=64, samples=64, api=api)
        results.append(r)
        log(f"{model:12s} {variant:50s} max albedo {r['max_albedo']:.4f} "
            f"(<= {r['tolerance']:.4f}) {report.verdict(r['pass'])}")

    gallery_png = None
    labels = []
    if not args.quick:
        log("\n-- gallery")
        g = gallery.build_gallery(api)
        with verify.quiet():
            img = gallery.render_gallery(g)
        labels = g.labels
        report.write_png(out / "gallery.png", img)
        gallery_png = "gallery.png"
        docs_png = REPO_ROOT / "docs" / "gallery.png"
        shutil.copyfile(out / "gallery.png", docs_png)
        log(f"{g.resolution[0]}x{g.resolution[1]}, {g.samples} spp: {g.last_render_seconds:.1f}s "
            f"-> out/gallery.png, docs/gallery.png ({docs_png.stat().st_size // 1024} KB)")

    # images of each case
    case_images = []
    for r in results:
        if r["mode"] == "furnace":
            continue
        imgs = []
        base = _slug(f"{r['id']}_{r['mode']}")
        for j, p in enumerate(r["images"]):
            shown, ref = report.display_pair(p["rendered"], p["expected"], p["mask"])
            names = [f"img/{base}_{j}_{kind}.png" for kind in ("render", "reference", "error")]
            report.write_png(out / names[0], shown)
            report.write_png(out / names[1], ref)
            report.write_png(out / names[2], report.heat_map(p["rel_error"], p["mask"]), srgb=False)
            imgs.append((*names, p["light_dir"], p["max_rel_error"]))
        case_images.append((verify.summary(r), imgs))

    entries = [verify.summary(r) for r in results]
    polar = [report.polar_svg(model, params, title) for title, model, params in POLAR]
    elapsed = time.perf_counter() - t_start
    meta = (f"Blender {bpy.app.version_string}, Cycles CPU, gonio {res}x{res} px, 1 sample, "
            f"direct light only; exact-mode tolerance {cases_mod.EXACT_MODE_TOLERANCE:g}, "
            f"path-traced: exact closures {cases_mod.PATH_TRACED_TOLERANCE['exact']:g}, "
            f"near {cases_mod.PATH_TRACED_TOLERANCE['near']:g}, approximations measured only. "
            f"Run time {elapsed:.0f} s.")
    report.write_json(out / "report.json", entries)
    report.write_html(out / "report.html", entries=entries, case_images=case_images,
                      gallery_png=gallery_png, gallery_labels=labels, polar_plots=polar,
                      meta=meta)

    companion_failed = _companion_pages(out, args)

    log("\n== summary ==")
    log(report.summary_table(entries))
    failed = [e for e in entries if e["pass"] is False]
    n_pass = sum(e["pass"] is True for e in entries)
    n_meas = sum(e["pass"] is None for e in entries)
    log(f"\n{n_pass} pass, {len(failed)} fail, {n_meas} measured without a tolerance "
        f"(Blender {version[0]}.{version[1]}); {time.perf_counter() - t_start:.0f} s")
    log(f"report: {out / 'report.html'}  json: {out / 'report.json'}")
    for e in failed:
        log(f"FAIL: {e['model']} [{e['variant']}] {e['mode']}: {e['max_rel_error']} > {e['tolerance']}")
    for name in companion_failed:
        log(f"FAIL: {name}")
    return 1 if failed or companion_failed else 0


def _companion_pages(out, args):
    """The anisotropy and hair figures (a section of report.html) and the
    lecture companion page (out/lecture.html, linked from the report).
    Returns the names of failed checks."""
    import html

    from test_scenes import anisotropy
    from tools import lecture_page, report

    failed = []
    log("\n-- anisotropic reflection and hair")
    figs = anisotropy.figures(str(out / "anisotropy"))
    section = ["<h2 id='anisotropy-and-hair'>Anisotropic reflection and hair</h2>",
               "<p class='small'>Exact mode on a cylinder, a brushed disc under a point light "
               "and real hair curves, against addon.reference on the known geometry "
               "(docs/anisotropy.md).</p><table><tr><th>figure</th><th>check</th>"
               "<th>measured</th><th>expected</th><th>result</th></tr>"]
    for f in figs:
        c = f["check"]
        verdict = report.verdict(c["pass"])
        rel = os.path.relpath(f["image_path"], out)
        section.append(f"<tr><td><img src='{html.escape(rel)}' style='max-width:240px'></td>"
                       f"<td>{html.escape(c['name'])}</td><td>{html.escape(str(c['measured']))}</td>"
                       f"<td>{html.escape(str(c['expected']))}</td>"
                       f"<td class='{verdict}'>{verdict}</td></tr>")
        log(f"  {verdict:8s} {c['name']}: {c['measured']}")
        if c["pass"] is False:
            failed.append(c["name"])
    section.append("</table><h2>Lecture companion</h2><p><a href='lecture.html'>The lecture's "
                   "figures and experiments, each with its check</a></p>")
    page = (out / "report.html").read_text()
    (out / "report.html").write_text(page.replace("</body>", "\n".join(section) + "</body>"))

    log("\n-- lecture companion")
    checks = lecture_page.build(str(out))
    for c in checks:
        verdict = report.verdict(c["pass"])
        log(f"  {verdict:8s} {c['name']}: {c.get('measured', '')}")
        if c["pass"] is False:
            failed.append(c["name"])
    log(f"-> {out / 'lecture.html'}")
    return failed


if __name__ == "__main__":
    main()
