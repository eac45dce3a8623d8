# SPDX-License-Identifier: GPL-3.0-or-later
"""The lecture companion page: every figure of ``test_scenes/lecture.py`` with
its caption, the slide it reproduces and the status of its check.

    python -m tools.lecture_page OUT_DIR [--fast] [--no-render]

writes ``OUT_DIR/lecture.html`` and prints one line per check; the exit status
is 1 when a check fails.  From Python (the demo's report)::

    from tools import lecture_page
    checks = lecture_page.build(out_dir)   # list of check dicts

The glitter figure renders with Cycles (bpy imported through
``tools.bpy_env.prepare``); ``render=False`` leaves it out.  The last section
links to the anisotropic and hair figures of ``OUT_DIR/report.html`` when that
page has such a section (build this page after the report to get the link).
"""

from __future__ import annotations

import argparse
import html
import os
import re
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
.slide { color: #666; font-size: 0.9em; }
.fig svg { margin: 0.5em 0.5em 0.5em 0; vertical-align: top; border: 1px solid #eee; }
.check { border-left: 5px solid; padding: 0.4em 0.8em; margin: 0.6em 0; background: #fafafa; }
.pass { border-color: #2a2; } .fail { border-color: #d22; }
.status { font-weight: bold; } .pass .status { color: #2a2; } .fail .status { color: #d22; }
table.summary { border-collapse: collapse; } table.summary td, table.summary th
 { border-bottom: 1px solid #ddd; padding: 0.2em 0.8em; text-align: left; }
.detail { color: #444; font-size: 0.9em; }
"""


def _find_companion_section(out_dir: Path):
    """(href, label) of the anisotropic/hair section of ``report.html`` in
    ``out_dir``, or None when there is no such page or section."""
    report = out_dir / "report.html"
    if not report.is_file():
        return None
    text = report.read_text(encoding="utf-8", errors="replace")
    for key in ("anisotrop", "hair", "kajiya", "ward"):
        m = re.search(r'id="([^"]*' + key + r'[^"]*)"', text, re.IGNORECASE)
        if m:
            return f"report.html#{m.group(1)}", m.group(1)
    return None


def _status(check):
    return "PASS" if check["pass"] else "FAIL"


def _section(fid, title, slide, caption, svg, check):
    cls = "pass" if check["pass"] else "fail"
    return f"""
<section id="{html.escape(fid)}">
<h2>{html.escape(title)}</h2>
<p class="slide">Slide: {html.escape(slide)}</p>
<p>{html.escape(caption)}</p>
<div class="fig">{svg}</div>
<div class="check {cls}">
<p><span class="status">{_status(check)}</span> &mdash; {html.escape(check['name'])}</p>
<p><b>Measured:</b> {html.escape(str(check['measured']))}</p>
<p><b>Expected:</b> {html.escape(str(check['expected']))}</p>
<p class="detail">{html.escape(str(check['detail']))}</p>
<p class="detail">Computed in {check.get('seconds', float('nan')):.2f} s.</p>
</div>
</section>"""


def build(out_dir, *, fast=False, render=True):
    """Write ``out_dir/lecture.html`` and return the list of check dicts
    (``name``, ``pass``, ``measured``, ``expected``, ``detail``, ``seconds``,
    and ``figure``, the figure's id on the page)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if render:
        from tools import bpy_env
        bpy_env.prepare()  # before anything imports bpy
    from test_scenes import lecture

    t0 = time.perf_counter()
    results = lecture.run_all(fast, render=render)
    total = time.perf_counter() - t0
    checks = []
    for fid, title, *_rest, check in results:
        check = dict(check)
        check["figure"] = fid
        checks.append(check)

    rows = "\n".join(
        f'<tr><td><a href="#{fid}">{html.escape(title)}</a></td>'
        f'<td class="{"pass" if c["pass"] else "fail"}"><span class="status">{_status(c)}</span></td>'
        f'<td>{c.get("seconds", 0):.2f} s</td></tr>'
        for (fid, title, *_r, c) in results)
    n_pass = sum(c["pass"] for c in checks)
    sections = "\n".join(_section(*r) for r in results)
    link = _find_companion_section(out_dir)
    models = ("Ward's anisotropic lobe and the Kajiya-Kay hair model (slides \"Anisotropic "
              "Reflection Model\" to \"Hair Model\")")
    if link:
        aniso = (f'<p>{html.escape(models)} have their own figures in the main report: '
                 f'<a href="{html.escape(link[0])}">{html.escape(link[1])}</a>.</p>')
    else:
        aniso = (f"<p>{html.escape(models)} are figures of the main report (report.html), "
                 "which was not beside this page when it was built.</p>")
    skipped = "" if render else "<p>The glitter render was left out (render=False).</p>"
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Reflection Models: the lecture, reproduced</title>
<style>{CSS}</style></head><body>
<h1>The lecture, reproduced</h1>
<p>Companion to CS348B Lecture 11, "Reflection Models" (Pat Hanrahan, 2002): each
figure below is computed from the extension's numpy reference (<code>addon/reference.py</code>)
or rendered with Cycles, and carries a check. Slide errata follow
<code>shared/LECTURE-NOTES.md</code>.</p>
<p><b>{n_pass} of {len(checks)} checks pass</b> ({total:.1f} s{", fast settings" if fast else ""}).</p>
{skipped}
<table class="summary"><tr><th>Figure</th><th>Check</th><th>Time</th></tr>
{rows}
</table>
{sections}
<section id="anisotropic">
<h2>Anisotropic reflection and hair</h2>
{aniso}
</section>
</body></html>
"""
    tmp = out_dir / "lecture.html.tmp"
    tmp.write_text(page, encoding="utf-8")
    os.replace(tmp, out_dir / "lecture.html")
    return checks


def main(argv=None):
    ap = argparse.ArgumentParser(description="Write OUT_DIR/lecture.html, the lecture companion page.")
    ap.add_argument("out_dir")
    ap.add_argument("--fast", action="store_true", help="the test suite's smaller quadratures and render")
    ap.add_argument("--no-render", action="store_true", help="leave out the Cycles render (glitter path)")
    args = ap.parse_args(argv)
    checks = build(args.out_dir, fast=args.fast, render=not args.no_render)
    for c in checks:
        print(f"{_status(c)}  {c['figure']:<17} {c['seconds']:6.2f} s  {c['name']}")
        if not c["pass"]:
            print(f"      measured: {c['measured']}\n      expected: {c['expected']}")
    print(f"wrote {Path(args.out_dir) / 'lecture.html'}")
    return 0 if all(c["pass"] for c in checks) else 1


if __name__ == "__main__":
    status = main()
    sys.stdout.flush()
    if "bpy" in sys.modules:  # bpy 4.5 can hang at interpreter exit
        from tools import bpy_env
        bpy_env.cleanup()
        os._exit(status)
    sys.exit(status)
