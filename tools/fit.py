# SPDX-License-Identifier: GPL-3.0-or-later
"""Write the generated data of ``addon/core/fits`` (``python -m tools.fit``).

- the series coefficients (:mod:`fitting.series`; seconds);
- with ``--mixtures``, the fitted closure mixtures (:mod:`fitting.mixtures`;
  about four hours on two cores, resumable: each variant's fit
  is kept in build/fits), optionally ``--only KEY ...``; each variant
  ships the best of its fit and the single lobes of its kind
  (:mod:`fitting.assemble`);
- ``--collect``: the module from the fits made so far (``--collect --only
  KEY ...``: choose those variants again, keep the others as committed);
- ``--derive``: the Smith variants in alpha given their siblings in
  beta's fits, resampled (:mod:`fitting.reparam`; ``make fit`` runs it
  after the rest);
- ``--finish``: the choice's last step (the joint re-solve,
  :func:`fitting.assemble.finish`) applied to the committed module; with
  ``--halve``, then the width nodes halved (:mod:`fitting.halve`; ``make
  fit`` runs it for the variants in its HALVE);
- ``--toon``: Phong's mixture of Toon glossy lobes for Cycles' native
  nodes (:mod:`fitting.toon`; about 45 minutes, on two cores, kept in
  build/fits);
- ``--ward``: how far Ward's BSDF output (a weighted Beckmann lobe, no
  fit) is from the model, cell by cell of its widths (:mod:`fitting.ward`;
  about 6 minutes on two cores; ``make fit`` runs it);
- ``--kajiya-kay``: the same for Kajiya-Kay's (a diffuse and a hair
  reflection closure, no fit), cell by cell of its exponent and its
  colours' ratio (:mod:`fitting.kajiya_kay`; about a minute);
- ``--bounds``: where each microfacet mixture holds the fitted bound,
  interval by interval of its width nodes, without and with the model's
  Fresnel (:mod:`fitting.bounds`; about 21 minutes on two cores; ``make
  fit`` runs it last);
- ``--edge``: the weight series of the nodes around the width intervals
  that ``--bounds``' measure finds over the bound solved together again,
  with the lights on the domain's edge, one interval at a time, where that
  ships
  (:func:`fitting.assemble.finish_edge`; ``make fit`` runs it for the
  variants in its EDGE, after the moves);
- ``--move``: the members' widths of the nodes around a Smith variant's
  worst widths moved, each node's series solved again, then those nodes'
  series solved together, where that ships (:mod:`fitting.widths`; ``make
  fit`` runs it for the variants in its MOVE).
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


CACHE = ROOT / "build" / "fits"


def _kept(cached, label, make, extra=None):
    """``make()``, a fit, kept in build/fits as ``cached`` (named by its
    fitter's hash, so an interrupted run resumes where it stopped);
    ``extra(measured)``: more words for its summary line."""
    import pickle

    if cached.exists():
        print(f"{label}: from {cached.relative_to(ROOT)}", flush=True)
        return pickle.loads(cached.read_bytes())
    t0 = time.perf_counter()
    fit = make()
    CACHE.mkdir(parents=True, exist_ok=True)
    cached.write_bytes(pickle.dumps(fit))
    m = fit.measured
    print(f"{label}: max |d|/peak {m['max_abs_over_peak_70']:.4f} (70 deg), "
          f"{m['max_abs_over_peak_85']:.4f} (85 deg), albedo {m['albedo_difference_70']:.4f} "
          f"({m['albedo_difference_85']:.4f}){extra(m) if extra else ''}, "
          f"{time.perf_counter() - t0:.0f} s", flush=True)
    return fit


def _fit(key):
    """One variant's fit (:func:`_kept`)."""
    from fitting import mixtures
    target = {t.key: t for t in mixtures.targets()}[key]
    return _kept(CACHE / f"{mixtures.fitter_hash()}-{key.replace('/', '-')}.pickle", key,
                 lambda: mixtures.fit_variant(target, log=lambda msg: print(msg, flush=True)),
                 extra=lambda m: f", beyond alpha 1 {m['beyond_70']:.4f}")


def _choose(key):
    """The shipped data of one variant (:func:`fitting.assemble.choose`)."""
    import pickle

    from fitting import assemble, mixtures
    target = {t.key: t for t in mixtures.targets()}[key]
    cached = CACHE / f"{mixtures.fitter_hash()}-{key.replace('/', '-')}.pickle"
    fit = pickle.loads(cached.read_bytes()) if cached.exists() else None
    lines = []
    shipped, how = assemble.choose(target, fit, log=lines.append)
    print("\n".join(lines + [f"{key}: ships {how}: "
                              f"{shipped.measured['max_abs_over_peak_70']:.4f}"]), flush=True)
    return shipped, how


def collect(jobs=2, only=None):
    """The module from the fits in build/fits: each variant ships the best
    of its fit (spliced with the weighted single lobe where that helps) and
    the single lobes of its kind (:mod:`fitting.assemble`); a fit never
    makes a variant worse than its stand-in.  Variants with no fitted width
    are listed in ``NOT_FITTED``, what each ships in ``SHIPPED``.  With
    ``only``, those variants are chosen again and the others kept as the
    committed module has them (which must come from the same fitter)."""
    from fitting import mixtures
    keys = [t.key for t in mixtures.targets()]
    _redo(_choose, list(only) if only else keys, keys, jobs)


def _finish(key, step="finish", **options):
    """One committed variant with ``fitting.assemble.<step>`` applied
    (:func:`fitting.assemble.finish`, ``halving=True``: and its width nodes
    halved, :mod:`fitting.halve`; ``finish_moved``: its members' widths
    moved, :mod:`fitting.widths`)."""
    from addon.core.fits import mixtures as data
    from fitting import assemble, halve, mixtures
    halve.CACHE_DIR = CACHE  # the steps' results kept: a run resumes
    fit = mixtures.load_fits([key])[key]
    fit.measured = mixtures.measure(fit)
    out = getattr(assemble, step)(fit, data.SHIPPED[key],
                                  log=lambda msg: print(msg, flush=True), **options)
    print(f"{key}: ships {out[1]}: {out[0].measured['max_abs_over_peak_70']:.4f}", flush=True)
    return out


def finish(jobs=2, only=None, halving=False):
    """The committed module with the last step of the choice
    (:func:`fitting.assemble.finish`: the joint re-solve of the Smith
    variants) applied to the variants ``only`` (default: every Smith
    variant and Blinn-Phong that ships no single lobe), the others kept: what
    ``collect`` makes from fits collected before those steps existed.
    ``halving``: the width nodes halved too (fitting/halve.py; ``make
    fit`` runs it for the variants in its HALVE)."""
    from addon.core.fits import mixtures as data
    from fitting import assemble, mixtures
    targets = {t.key: t for t in mixtures.targets()}
    todo = only or [k for k in targets if assemble.joint_step(targets[k])
                    and not data.SHIPPED[k].startswith("single lobe")]
    _redo(functools.partial(_finish, halving=halving), todo, list(targets), jobs,
          committed=True)


def _derive(key):
    """One committed variant in alpha, given its sibling in beta's fit where
    that ships (:func:`fitting.reparam.finish_derived`)."""
    from addon.core.fits import mixtures as data
    from fitting import mixtures, reparam
    fits = mixtures.load_fits([key, reparam.SIBLINGS[key]])
    fit = fits[key]
    fit.measured = mixtures.measure(fit)
    out = reparam.finish_derived(fit, data.SHIPPED[key], fits[reparam.SIBLINGS[key]],
                                 log=lambda msg: print(msg, flush=True))
    print(f"{key}: ships {out[1]}: {out[0].measured['max_abs_over_peak_70']:.4f}", flush=True)
    return out


def derive(jobs=2, only=None):
    """The committed module with the variants in alpha given their siblings
    in beta's fits where that is better (:mod:`fitting.reparam`; ``only``:
    those of them named, or whose sibling is), the others kept."""
    from fitting import mixtures, reparam
    todo = [a for a, b in reparam.SIBLINGS.items() if not only or a in only or b in only]
    if not todo:
        print("no variant in alpha to derive")
        return
    _redo(_derive, todo, [t.key for t in mixtures.targets()], jobs, committed=True)


def move(jobs=2, only=None, sweeps=None):
    """The committed module with the variants ``only`` (default: the
    Smith variants) given :func:`fitting.assemble.finish_moved` (``sweeps``
    sweeps of moves; default :data:`fitting.widths.SWEEPS`), the others
    kept."""
    from fitting import widths
    _smith_step(jobs, only, step="finish_moved", sweeps=sweeps or widths.SWEEPS)


def edge(jobs=2, only=None):
    """The committed module with the variants ``only`` (default: the Smith
    variants) given :func:`fitting.assemble.finish_edge`, the others
    kept."""
    _smith_step(jobs, only, step="finish_edge")


def _smith_step(jobs, only, **options):
    """The committed module with the variants ``only`` (default: the Smith
    variants, :func:`fitting.assemble.re_solved`) given :func:`_finish`
    with ``options``, the others kept."""
    from fitting import assemble, mixtures
    targets = {t.key: t for t in mixtures.targets()}
    todo = only or [k for k, t in targets.items() if assemble.re_solved(t)]
    _redo(functools.partial(_finish, **options), todo, list(targets), jobs, committed=True)


def toon(jobs=2):
    """``addon/core/fits/toon.py`` (:mod:`fitting.toon`; the fit kept by
    :func:`_kept`; ``jobs``: processes for each node's two starts)."""
    import pickle

    from fitting import FITS
    from fitting import toon as T
    log = functools.partial(print, flush=True)
    cached = CACHE / f"{T.fitter_hash()}-phong-toon.pickle"
    fit = _kept(cached, "phong toon", lambda: T.fit(log=log, jobs=jobs))
    if getattr(fit, "glossy", None) != T.glossy_digest():
        # Phong's Glossy mixture changed since: its band and the measure again
        # (13 s measured; the floors are the fit's), the nodes' fit kept (it
        # does not use the Glossy mixture)
        print("phong toon: the Glossy mixture changed: band and measure again", flush=True)
        fit = T.against_glossy(fit, log)
        cached.write_bytes(pickle.dumps(fit))
    path = FITS / "toon.py"
    path.write_text(T.module_text(fit))
    print(f"wrote {path.relative_to(ROOT)}")


def bounds(jobs=2):
    """``addon/core/fits/bounds.py`` (:mod:`fitting.bounds`), from the
    committed mixtures."""
    from concurrent.futures import ProcessPoolExecutor

    from fitting import FITS
    from fitting import bounds as B
    keys = B.keys()
    with ProcessPoolExecutor(jobs) as pool:
        measured = dict(zip(keys, pool.map(B.measure_key, keys)))
    path = FITS / "bounds.py"
    path.write_text(B.module_text(measured))
    print(f"wrote {path.relative_to(ROOT)}")


def ward(jobs=2):
    """``addon/core/fits/ward.py`` (:mod:`fitting.ward`): how far Ward's BSDF
    output is from the model, cell by cell of its widths."""
    from fitting import ward as W
    points = W.points()
    _write_measured("ward.py", W.module_text, dict(zip(points, _mapped(
        W.measure_point, points, jobs, chunksize=8))))


def kajiya_kay(jobs=2):
    """``addon/core/fits/kajiya_kay.py`` (:mod:`fitting.kajiya_kay`): how far
    Kajiya-Kay's BSDF output is from the model, cell by cell of its exponent
    and colour ratio."""
    from fitting import kajiya_kay as K
    _write_measured("kajiya_kay.py", K.module_text, _mapped(K.measure, K.points(), jobs))


def _mapped(function, items, jobs, chunksize=1) -> list:
    """``function`` of each of ``items``, in ``jobs`` processes."""
    from concurrent.futures import ProcessPoolExecutor
    with ProcessPoolExecutor(jobs) as pool:
        return list(pool.map(function, items, chunksize=chunksize))


def _write_measured(name, module_text, measured) -> None:
    """``addon/core/fits/<name>`` from a measure's results."""
    from fitting import FITS
    path = FITS / name
    path.write_text(module_text(measured))
    print(f"wrote {path.relative_to(ROOT)}")


def _check_committed(todo, keys):
    """Exit unless the committed module comes from this fitter (so its other
    variants can be kept) and ``todo`` are variants."""
    from addon.core.fits import mixtures as data
    from fitting import mixtures
    if data.FITTER != mixtures.fitter_hash():
        raise SystemExit("the committed mixtures come from another fitter: collect them all")
    unknown = set(todo) - set(keys)
    if unknown:
        raise SystemExit(f"no such variants: {sorted(unknown)}")


def _redo(work, todo, keys, jobs, committed=False):
    """The module with ``work(key) -> (Fit, how)`` for the variants
    ``todo``, the others kept as the committed module has them (which must
    then come from the same fitter, as must the module ``work`` starts
    from where ``committed``)."""
    from concurrent.futures import ProcessPoolExecutor

    from fitting import mixtures
    chosen, kept = {}, []
    if committed or set(todo) != set(keys):
        from addon.core.fits import mixtures as data
        _check_committed(todo, keys)
        kept = [k for k in keys if k not in todo]
        chosen = {k: (fit, data.SHIPPED[k]) for k, fit in mixtures.load_fits(kept).items()}
    if jobs == 1:  # in this process
        chosen.update(zip(todo, map(work, todo)))
    else:
        with ProcessPoolExecutor(jobs) as pool:
            chosen.update(zip(todo, pool.map(work, todo)))
    if committed:  # a variant the step left as it was keeps its committed text
        from fitting.assemble import left_as_they_were
        kept += left_as_they_were({k: chosen[k] for k in todo}, mixtures.load_fits(todo),
                                  data.SHIPPED)
    _write(chosen, keys, kept)


def _write(chosen, keys, kept=()):
    """The module; the variants ``kept`` keep their committed text byte
    for byte (a round trip through :func:`fitting.mixtures.load_fits`
    changes their series in the last digits)."""
    from fitting import FITS, mixtures
    missing = tuple(k for k in keys if chosen[k][1].startswith("single lobe"))
    shipped = {k: chosen[k][1] for k in keys}
    path = FITS / "mixtures.py"
    text = mixtures.module_text([chosen[k][0] for k in keys])
    if kept:
        from fitting.codegen import keep_entries
        text = keep_entries(text, path.read_text(), kept)
    path.write_text(text
                    + "\n# variants with no fitted width: a single lobe of their kind at the\n"
                    "# equivalent width (fitting/assemble.py), measured like the fits\n"
                    f"NOT_FITTED = {missing!r}\n"
                    "# what each variant ships\n"
                    f"SHIPPED = {shipped!r}\n")
    print(f"wrote {path.relative_to(ROOT)}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mixtures", action="store_true", help="also fit the closure mixtures")
    parser.add_argument("--only", nargs="*", help="fit these mixture keys again and choose them "
                        "again (the others: as the committed module has them); with --collect, "
                        "choose only these again")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--finish", action="store_true",
                        help="apply the choice's last step (the joint re-solve) to the committed "
                             "mixtures (--only: to these variants)")
    parser.add_argument("--halve", action="store_true",
                        help="with --finish: also halve the width nodes of the Smith variants "
                             "still over the bound (fitting/halve.py; make fit runs it for the "
                             "variants in its HALVE)")
    parser.add_argument("--derive", action="store_true",
                        help="give the Smith variants in alpha their siblings in beta's fits, "
                             "resampled, where that measures better (fitting/reparam.py; --only: "
                             "those named or whose sibling is named); make fit runs it last")
    parser.add_argument("--move", action="store_true",
                        help="move the members' widths of the nodes around the worst widths of "
                             "the Smith variants still over the bound, each node's series solved "
                             "again, where that measures better (fitting/widths.py; --only: those "
                             "variants; make fit runs it for the variants in its MOVE, and "
                             "with --sweeps 1 for those in its MOVE_ONCE)")
    parser.add_argument("--sweeps", type=int, default=None,
                        help="with --move: the sweeps of moves before the moved fit's series "
                             "are solved together (default fitting.widths.SWEEPS, 2)")
    parser.add_argument("--edge", action="store_true",
                        help="solve the weight series of the nodes around the width intervals "
                             "over the bound together again, with the lights on the domain's "
                             "edge, one interval at a time, where that measures better "
                             "(fitting/assemble.py's finish_edge; --only: those variants; make "
                             "fit runs it for those in its EDGE)")
    parser.add_argument("--toon", action="store_true",
                        help="fit Phong's mixture of Toon glossy lobes for Cycles' native nodes "
                             "(fitting/toon.py) and write addon/core/fits/toon.py")
    parser.add_argument("--bounds", action="store_true",
                        help="measure where each microfacet mixture holds the fitted bound, per "
                             "width interval, without and with Fresnel (fitting/bounds.py) and "
                             "write addon/core/fits/bounds.py; make fit runs it last")
    parser.add_argument("--ward", action="store_true",
                        help="measure how far Ward's BSDF output is from the model, per cell "
                             "of its widths (fitting/ward.py), and write "
                             "addon/core/fits/ward.py; make fit runs it")
    parser.add_argument("--kajiya-kay", action="store_true",
                        help="measure how far Kajiya-Kay's BSDF output is from the model, per "
                             "cell of its exponent and colour ratio (fitting/kajiya_kay.py), "
                             "and write addon/core/fits/kajiya_kay.py; make fit runs it")
    parser.add_argument("--collect", action="store_true",
                        help="write the mixtures from the fits made so far (build/fits); the "
                             "others get the single lobe and are listed as not fitted")
    args = parser.parse_args(argv)
    if args.sweeps is not None and (not args.move or args.sweeps < 1):
        parser.error(f"--sweeps goes with --move and is 1 or more, not {args.sweeps}")
    if args.toon:
        toon(args.jobs)
        return 0
    if args.bounds:
        bounds(args.jobs)
        return 0
    if args.ward:
        ward(args.jobs)
        return 0
    if args.kajiya_kay:
        kajiya_kay(args.jobs)
        return 0
    if args.collect:
        collect(args.jobs, args.only)
        return 0
    if args.derive:
        derive(args.jobs, args.only)
        return 0
    if args.move:
        move(args.jobs, args.only, args.sweeps)
        return 0
    if args.edge:
        edge(args.jobs, args.only)
        return 0
    if args.finish:
        finish(args.jobs, args.only, halving=args.halve)
        return 0
    if args.only:  # the others are kept as committed: check that before any writing or fitting
        from fitting import mixtures
        _check_committed(args.only, [t.key for t in mixtures.targets()])
    from fitting import outputs
    for path, text in outputs().items():
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
            print(f"wrote {path.relative_to(ROOT)}")
    if args.mixtures or args.only:
        from concurrent.futures import ProcessPoolExecutor

        from fitting import mixtures
        todo = args.only or [t.key for t in mixtures.targets()]
        # the slowest (no shadowing: far off, every node tried) start first
        todo = sorted(todo, key=lambda k: "/none/" not in k)
        if args.only:  # fitted again: what build/fits holds for them goes
            for key in args.only:
                (CACHE / f"{mixtures.fitter_hash()}-{key.replace('/', '-')}.pickle").unlink(
                    missing_ok=True)
        with ProcessPoolExecutor(args.jobs) as pool:
            list(pool.map(_fit, todo))
        # every variant (with --only: those, the others kept as committed):
        # the best of its fit and the single lobes
        collect(args.jobs, args.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
