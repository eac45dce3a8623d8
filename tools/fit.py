# SPDX-License-Identifier: GPL-3.0-or-later
"""Write the generated data of ``addon/core/fits`` (``python -m tools.fit``).

- the series coefficients (:mod:`fitting.series`; seconds);
- with ``--mixtures``, the fitted closure mixtures (:mod:`fitting.mixtures`;
  about two and a half hours on two cores, resumable: each variant's fit
  is kept in build/fits), optionally ``--only KEY ...``; each variant
  ships the better of its fit and the single lobe of its kind;
- ``--collect``: the module from the fits made so far.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


CACHE = ROOT / "build" / "fits"


def _fit(key):
    """One variant's fit; kept in build/fits under the fitter's hash, so an
    interrupted run resumes where it stopped."""
    import pickle

    from fitting import mixtures
    target = {t.key: t for t in mixtures.targets()}[key]
    cached = CACHE / f"{mixtures.fitter_hash()}-{key.replace('/', '-')}.pickle"
    if cached.exists():
        print(f"{key}: from {cached.relative_to(ROOT)}", flush=True)
        return pickle.loads(cached.read_bytes())
    t0 = time.perf_counter()
    fit = mixtures.fit_variant(target, log=lambda msg: print(msg, flush=True))
    CACHE.mkdir(parents=True, exist_ok=True)
    cached.write_bytes(pickle.dumps(fit))
    m = fit.measured
    print(f"{key}: max |d|/peak {m['max_abs_over_peak_70']:.4f} (70 deg), "
          f"{m['max_abs_over_peak_85']:.4f} (85 deg), albedo {m['albedo_difference_70']:.4f} "
          f"({m['albedo_difference_85']:.4f}), beyond alpha 1 {m['beyond_70']:.4f}, "
          f"{time.perf_counter() - t0:.0f} s", flush=True)
    return fit


def single_lobe(target):
    """The stand-in a variant has without a fit: one lobe of its own kind
    (GGX for Trowbridge-Reitz, Ashikhmin-Shirley for Blinn-Phong, Beckmann
    otherwise) at the equivalent width, one weight for every view (1, or the
    peak's for the unnormalised lobes); measured like a fit."""
    import numpy as np

    from fitting import mixtures
    k = 0 if target.members[0] == "ashikhmin_shirley" or "trowbridge" in target.key else 1
    nodes = mixtures.width_nodes(target)
    views, _u = mixtures.view_nodes()
    weights = np.zeros((len(nodes), len(views), len(target.members)))
    if target.model in ("phong", "blinn_phong"):
        # (N.H)^s or cos^s peaks at 1, a lobe D/(4 cos cos) at 1/(4 pi alpha^2)
        weights[:, :, k] = [[4.0 * np.pi * target.equivalent_alpha(float(v)) ** 2]
                            for v in nodes]
    else:  # a normalised D: the lobe as it is
        weights[:, :, k] = 1.0
    fit = mixtures.Fit(target, np.asarray(nodes, float), np.zeros((len(nodes), len(target.members))),
                       weights, np.zeros(len(nodes)))
    fit.measured = mixtures.measure(fit)
    return fit


def collect(jobs=2):
    """The module from the fits in build/fits.  Every variant is also
    measured as the single lobe of its kind; where that is better than the
    fit (or no fit ran) the single lobe is shipped and the variant listed in
    ``NOT_FITTED``: a fit never makes a variant worse than its stand-in."""
    import pickle
    from concurrent.futures import ProcessPoolExecutor

    from fitting import FITS, mixtures
    targets = mixtures.targets()
    with ProcessPoolExecutor(jobs) as pool:
        lobes = dict(zip([t.key for t in targets], pool.map(single_lobe, targets)))
    fits, missing = {}, []
    for t in targets:
        cached = CACHE / f"{mixtures.fitter_hash()}-{t.key.replace('/', '-')}.pickle"
        lobe = lobes[t.key]
        one = lobe.measured["max_abs_over_peak_70"]
        fit = pickle.loads(cached.read_bytes()) if cached.exists() else None
        if fit is not None and fit.measured["max_abs_over_peak_70"] <= one:
            fits[t.key] = fit
            print(f"{t.key}: fitted {fit.measured['max_abs_over_peak_70']:.4f}, "
                  f"single lobe {one:.4f}", flush=True)
            continue
        why = "not fitted" if fit is None else \
            f"the fit measured {fit.measured['max_abs_over_peak_70']:.4f}"
        print(f"{t.key}: {why}; the single lobe {one:.4f}", flush=True)
        fits[t.key] = lobe
        missing.append(t.key)
    path = FITS / "mixtures.py"
    path.write_text(mixtures.module_text([fits[t.key] for t in targets])
                    + "\n# variants shipped as the single lobe of their kind at the equivalent\n"
                    "# width (measured like the fits): no fit has run, or it measured worse\n"
                    f"NOT_FITTED = {tuple(missing)!r}\n")
    print(f"wrote {path.relative_to(ROOT)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mixtures", action="store_true", help="also fit the closure mixtures")
    parser.add_argument("--only", nargs="*", help="refit these mixture keys, keep the others")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--collect", action="store_true",
                        help="write the mixtures from the fits made so far (build/fits); the "
                             "others get the single lobe and are listed as not fitted")
    args = parser.parse_args(argv)
    if args.collect:
        collect()
        return 0
    from fitting import outputs
    for path, text in outputs().items():
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
            print(f"wrote {path.relative_to(ROOT)}")
    if args.mixtures or args.only:
        from concurrent.futures import ProcessPoolExecutor

        from fitting import FITS, mixtures
        keys = [t.key for t in mixtures.targets()]
        todo = args.only or keys
        # the slowest (no shadowing: far off, every node tried) start first
        todo = sorted(todo, key=lambda k: "/none/" not in k)
        with ProcessPoolExecutor(args.jobs) as pool:
            fits = dict(zip(todo, pool.map(_fit, todo)))
        if not args.only:  # every fit is in build/fits: the better of it and the single lobe
            collect(args.jobs)
            return 0
        if args.only:  # keep the others as committed
            fits = {**mixtures.load_fits(keys), **fits}
        path = FITS / "mixtures.py"
        path.write_text(mixtures.module_text([fits[k] for k in keys]) + "NOT_FITTED = ()\n")
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
