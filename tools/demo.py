# SPDX-License-Identifier: GPL-3.0-or-later
"""The main command: ``make demo`` (``python -m tools.demo``).

1. Builds the extension zip with Blender's own tool and installs it into a
   clean headless Blender (throwaway user folders, ``tools.bpy_env``), and
   once more in a new process whose path holds no copy of the source tree
   (``verification.harness.installed_check``: every model and preset in
   both modes rendered lit and finite, OSL off and on).
2. Imports the **installed** extension's public API
   (``bl_ext.<repo>.reflection_models.api``) and runs every verification case
   of ``verification.suites.cases`` in both modes on the virtual
   gonioreflectometer, on each backend: the OSL shaders, the native nodes in
   Cycles with OSL off (the GPU devices' kernel code) and, for the models at
   their defaults, EEVEE; the native-Glossy oracle checks, the white
   furnace, exact mode under several lamps and the hybrid mode, the
   galleries (the models path traced; the three modes side by side), the
   anisotropy and hair scenes and the lecture's figures.
3. Prints progress and a summary table; writes ``out/report.html`` (renders,
   references, error heat maps, the gallery, polar plots of every lobe),
   ``out/lecture.html`` and ``out/report.json``, and copies the gallery to
   ``docs/gallery.png`` (the README's picture).

Exits 1 if any check with a tolerance is out of it.  Options: ``--resolution``
(gonio pixels, default 128), ``--quick`` (one light per case, no gallery).
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import re
import shutil
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
        from verification.harness import session
        session.exit_process(status)  # bpy 4.5 can hang at interpreter exit


def run(args):
    t_start = time.perf_counter()
    out = Path(args.out)
    img_dir = out / "img"
    if img_dir.exists():
        shutil.rmtree(img_dir)
    img_dir.mkdir(parents=True, exist_ok=True)

    from verification.harness import session
    from verification.harness.package import build_zip

    log("== Reflection Models: verification demo ==")
    zip_path = build_zip()
    log(f"built {zip_path.relative_to(REPO_ROOT)}")
    bpy = session.prepare()
    module = session.install_extension(zip_path)
    api = importlib.import_module(module + ".api")
    log(f"installed into a clean Blender {bpy.app.version_string}; using {api.__name__}")
    import tempfile

    from verification.harness import installed_check
    with tempfile.TemporaryDirectory(prefix="rm-installed-") as work:
        alone = installed_check.run(zip_path, work)  # raises if it fails
    if installed_check.problems(alone):
        raise RuntimeError("the installed extension, away from the source tree: "
                           + "; ".join(installed_check.problems(alone)))
    log(f"installed again where the source tree is out of reach: {alone['nodes']} nodes "
        "(every model and preset, both modes) rendered lit and finite, OSL off and on")

    from report import anisotropy as report_aniso
    from report import lecture as report_lecture
    from report import pages
    from verification.scenes import gallery
    from verification.suites import anisotropy, lecture, verify
    from verification.suites import cases as cases_mod

    version = verify.blender_version()
    res = args.resolution
    light_dirs = cases_mod.LIGHT_DIRS[:1] if args.quick else cases_mod.LIGHT_DIRS
    theta_d = cases_mod.THETA_D_SWEEP[:2] if args.quick else cases_mod.THETA_D_SWEEP
    checks = []
    all_cases = cases_mod.CASES
    eevee_cases = [c for c in all_cases if c.variant in ("default", "preset")
                   or c.id.startswith("microfacet[default")]
    runs = [(case, backend) for backend in ("osl", "svm") for case in all_cases]
    runs += [(case, "eevee") for case in eevee_cases]
    total = 2 * len(runs)
    log(f"\n-- gonioreflectometer: {len(all_cases)} cases x 2 modes on OSL and native nodes "
        f"(Cycles, OSL off), {len(eevee_cases)} on EEVEE; {res}x{res} px, "
        f"{len(light_dirs)} lights (Fresnel: theta_d {', '.join(f'{t:g}' for t in theta_d)} deg)")
    k = 0
    for case, backend in runs:
        for mode in ("exact", "path_traced"):
            k += 1
            kw = {}
            if backend == "eevee":  # its screen-space shadow rays: lights above the view plane
                kw = dict(light_dirs=cases_mod.LIGHT_DIRS[:1], theta_d=(15.0, 30.0),
                          resolution=min(res, 64))
            c = verify.run_case(case, mode, **{"resolution": res, "light_dirs": light_dirs,
                                               "theta_d": theta_d, **kw},
                                api=api, backend=backend)
            checks.append(c)
            log(f"[{k:3d}/{total}] {case.id:56.56s} {backend:5s} {mode:11s} "
                f"{c.values['status']:6s} max {c.values['max_rel_error']:.2e} |d|/peak "
                f"{c.values['max_abs_over_peak']:.2e} {c.verdict:8s} {c.seconds:.2f}s"
                + (f" ({c.values['false_shadow_pixels']} px shadowed by the screen-space ray)"
                   if c.values.get("false_shadow_pixels") else ""))

    log("\n-- independent oracle: exact mode vs Blender's native Glossy BSDF")
    for dist, alpha in (("trowbridge_reitz", 0.3), ("beckmann", 0.3), ("beckmann", 0.8)):
        c = verify.run_oracle(dist, alpha, resolution=res, light_dirs=light_dirs, api=api)
        checks.append(c)
        log(f"{c.values['variant']:70s} max {c.values['max_rel_error']:.2e} "
            f"(tol {c.values['tolerance']:.0e}) {c.verdict}")

    log("\n-- white furnace: path-traced energy-normalised models reflect <= 1")
    for model, params, variant in verify.FURNACE_CASES:
        c = verify.run_furnace(model, params, variant, resolution=64, samples=64, api=api)
        checks.append(c)
        log(f"{model:12s} {variant:50s} max albedo {c.values['max_albedo']:.4f} "
            f"(<= {c.values['tolerance']:.4f}) {c.verdict}")

    log("\n-- several lamps in exact mode, and the hybrid mode")
    from verification.suites import lighting
    lamp_checks = []
    for lamps in ("four", "spots"):
        for model, params in (("lambert", {}), ("microfacet", lighting.TR), ("kajiya_kay", {}),
                              ("ward", {})):
            for osl in (True, False):
                lamp_checks.append(lighting.several_lamps(api, lamps, model, params, osl=osl))
            # EEVEE for the surface models: a lamp behind a tile reaches Kajiya-Kay's
            # fibres, and EEVEE's screen-space shadow ray counts them shadowed there
            # (docs/compatibility.md)
            if model != "kajiya_kay":
                lamp_checks.append(lighting.several_lamps(api, lamps, model, params, osl=False,
                                                          eevee=True))
    from addon import catalogue as _catalogue
    for model in _catalogue.names():
        for osl in (True, False):
            lamp_checks.append(lighting.hybrid_bound_lamp(api, model, osl=osl))
        # EEVEE honours the light linking too: the bound sun reaches the Direct output only
        lamp_checks.append(lighting.hybrid_bound_lamp(api, model, osl=False, eevee=True))
    # the light linking finds the material's objects through a user's group, Geometry Nodes
    # and instancing
    for placement in ("group", "geometry_nodes", "instance"):
        lamp_checks.append(lighting.hybrid_bound_lamp(api, "cook_torrance", osl=False,
                                                      placement=placement))
    # EEVEE does not apply an instanced object's own exclusion: its render shows the instancer's
    lamp_checks.append(lighting.hybrid_bound_lamp(api, "cook_torrance", osl=False, eevee=True,
                                                  placement="instance"))
    # a copy of a bound lamp gets the original's light linking from Blender: the extension
    # takes it away, and lamps bound together share one collection
    for eevee in (False, True):
        lamp_checks.append(lighting.hybrid_copied_lamp(api, osl=False, eevee=eevee))
    # what decides whether the engine renders the bound lamp, followed by exact mode
    for osl, eevee in ((True, False), (False, False), (False, True)):
        lamp_checks.append(lighting.lamp_switches(api, osl=osl, eevee=eevee))
    for osl in (True, False):
        lamp_checks.append(lighting.hybrid_lit_scene(api, samples=128, resolution=64, osl=osl))
    for c in lamp_checks:
        log(f"  {c.verdict:8s} {c.name}: {c.measured}")

    gallery_entry = None
    modes_entry = None
    if not args.quick:
        log("\n-- gallery")
        g = gallery.build_gallery(api)
        with verify.quiet():
            img = gallery.render_gallery(g)
        pages_png = out / "gallery.png"
        from verification import harness
        harness.write_png(pages_png, img)
        docs_png = REPO_ROOT / "docs" / "gallery.png"
        shutil.copyfile(pages_png, docs_png)
        gallery_entry = ("gallery.png", "Path-traced BSDF outputs, left to right: "
                         + ", ".join(g.labels))
        log(f"{g.resolution[0]}x{g.resolution[1]}, {g.samples} spp: {g.last_render_seconds:.1f}s "
            f"-> out/gallery.png, docs/gallery.png ({docs_png.stat().st_size // 1024} KB)")
        m = gallery.build_modes_gallery(api)
        with verify.quiet():
            img = gallery.render_gallery(m)
        harness.write_png(out / "modes.png", img)
        shutil.copyfile(out / "modes.png", REPO_ROOT / "docs" / "modes.png")
        modes_entry = "modes.png"
        log(f"modes: {m.resolution[0]}x{m.resolution[1]}, {m.samples} spp: "
            f"{m.last_render_seconds:.1f}s -> out/modes.png, docs/modes.png")

    log("\n-- anisotropic reflection and hair")
    aniso = anisotropy.checks()
    for c in aniso:
        log(f"  {c.verdict:8s} {c.name}: {c.measured}")
    aniso_rows = [(c, [str(Path(p).relative_to(out)) for p in paths])
                  for c, paths in report_aniso.write_images(aniso, out / "anisotropy")]

    case_images = [(c, pages.write_case_images(c, img_dir, out)) for c in checks
                   if c.values["mode"] != "furnace"]
    polar = [pages.polar_svg(model, params, title) for title, model, params in POLAR]
    elapsed = time.perf_counter() - t_start
    meta = (f"Blender {bpy.app.version_string}; Cycles CPU with OSL (osl) and with OSL off "
            f"(svm: native nodes, the GPU devices' kernel code), EEVEE (eevee, software "
            f"OpenGL); gonio {res}x{res} px, 1 sample, direct light only; exact-mode tolerance "
            f"{cases_mod.EXACT_MODE_TOLERANCE:g} (EEVEE: 3e-3 of the peak, half-float output, "
            f"on the pixels its screen-space shadow ray does not blacken: at most 1 % of "
            f"them), "
            f"path-traced: exact closures {cases_mod.PATH_TRACED_TOLERANCE['exact']:g}, "
            f"near {cases_mod.PATH_TRACED_TOLERANCE['near']:g}, fitted mixtures "
            f"{cases_mod.PATH_TRACED_TOLERANCE['fitted']:g} of the model's peak with view and "
            f"light within 70 deg (the fitter's domain), approximations the fitter's "
            f"figure at their width there (what api.bsdf_accuracy states) where it measured "
            f"one, else measured only. Run time {elapsed:.0f} s.")
    pages.write_json(out / "report.json", checks + aniso + lamp_checks)
    from report import docs
    docs.MEASURED.write_text(json.dumps(docs.measured_rows(checks, bpy.app.version_string),
                                        indent=1) + "\n")
    for path in docs.write():
        log(f"wrote {path.relative_to(REPO_ROOT)}")
    modes_html = (f'<img src="{modes_entry}" style="max-width:100%"><p class="small">Rows: '
                  "path traced (the BSDF output), exact (the bound sun and point lamp only), "
                  "hybrid (those two exactly, the sky and the bounces path traced); under a "
                  "sun, a point lamp and a sky.</p>" if modes_entry else "")
    sections = [("lamps", "Several lamps and the hybrid mode",
                 modes_html + pages.checks_table_html(lamp_checks)),
                ("fits", "Fitted closure mixtures (the path-traced output)",
                 '<p class="small">As the offline fitter (fitting/mixtures.py) measured each '
                 "mixture between its nodes against addon.reference; 'fitted' within "
                 "0.025 of the peak over views and lights up to 70°.</p>"
                 + pages.fits_table_html())]
    pages.write_html(out / "report.html", checks=checks, case_images=case_images,
                     gallery=gallery_entry, polar_plots=polar, anisotropy=aniso_rows, meta=meta,
                     sections=sections)

    log("\n-- lecture companion")
    t0 = time.perf_counter()
    results = lecture.run_all(api=api)
    report_lecture.write(out, results, seconds=time.perf_counter() - t0,
                         report_section=("report.html#anisotropy-and-hair",
                                         "Anisotropic reflection and hair"))
    for _fig, _data, c in results:
        log(f"  {c.verdict:8s} {c.name}: {c.measured}")
    log(f"-> {out / 'lecture.html'}")

    log("\n== summary ==")
    log(pages.summary_table(checks))
    every = checks + aniso + lamp_checks + [c for _f, _d, c in results]
    failed = [c for c in every if c.passed is False]
    n_pass = sum(c.passed is True for c in every)
    n_meas = sum(c.passed is None for c in every)
    log(f"\n{n_pass} pass, {len(failed)} fail, {n_meas} measured without a tolerance "
        f"(Blender {version[0]}.{version[1]}); {time.perf_counter() - t_start:.0f} s")
    log(f"report: {out / 'report.html'}  json: {out / 'report.json'}")
    for c in failed:
        log(f"FAIL: {c.name}: {c.measured} (expected {c.expected})")
    return 1 if failed else 0


if __name__ == "__main__":
    main()
