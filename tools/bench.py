# SPDX-License-Identifier: GPL-3.0-or-later
"""Benchmarks: ``make bench`` (``python -m tools.bench``).

Prints tables; asserts nothing (speed is measured here, never in tests):

* reference: throughput of ``addon.reference.shade`` per model on one core,
  and its working memory (:mod:`verification.bench.reference`);
* render: render time of each node mode relative to the native Glossy BSDF
  (:mod:`verification.bench.render`);
* count: the same ratio in instructions per frame under callgrind, which is
  repeatable where time is not (:mod:`verification.bench.count`; needs
  valgrind);
* build: the time to add a node of a variant not yet in the file, its
  native nodes built in nested parts and in one tree
  (:mod:`verification.bench.build`);
* linking: the hybrid mode's light linking (binding, an update, the
  sidebar's check, the viewport's handler) with 200 to 10,000 objects
  (:mod:`verification.bench.linking`);
* eevee: EEVEE's shader compile time per model against a Principled BSDF,
  the peak memory of a process rendering each model (EEVEE, Cycles with OSL
  off and on), and the native node count per model
  (:mod:`verification.bench.eevee`).
"""

from __future__ import annotations

import argparse
import os
import sys

# One core for numpy's helpers too (elementwise numpy is single-threaded anyway).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", action="store_true", help="only the reference table")
    parser.add_argument("--render", action="store_true", help="only the render-time table")
    parser.add_argument("--count", action="store_true", help="only the instruction-count table")
    parser.add_argument("--build", action="store_true", help="only the group build-time table")
    parser.add_argument("--linking", action="store_true",
                        help="only the hybrid light-linking table")
    parser.add_argument("--eevee", action="store_true",
                        help="only the EEVEE compile-time, memory and node-count tables")
    parser.add_argument("-n", type=int, default=1_000_000, help="batch size for the reference")
    args = parser.parse_args(argv)
    every = not (args.reference or args.render or args.count or args.eevee or args.build
                 or args.linking)
    if args.reference or every:
        from verification.bench import reference
        reference.bench_reference(args.n)
    if args.render or every:
        from verification.bench import render
        render.main([])
    if args.build or every:
        import subprocess
        # its own process: a file holding nothing but the groups it builds
        subprocess.run([sys.executable, "-m", "verification.bench.build"], check=False)
    if args.linking or every:
        import subprocess
        # its own process: a file holding nothing but the scene it times
        subprocess.run([sys.executable, "-m", "verification.bench.linking"], check=False)
    if args.eevee or every:
        import subprocess
        # its own process: EEVEE's GPU context beside the render benchmarks' Cycles
        subprocess.run([sys.executable, "-m", "verification.bench.eevee"], check=False)
    status = 0
    if args.count or every:
        from verification.bench import count
        status = count.main([])
    return status


if __name__ == "__main__":
    sys.exit(main())
