# SPDX-License-Identifier: GPL-3.0-or-later
"""Offline numerics that produce the data in ``addon/core/fits`` (numpy,
mpmath; development only, never shipped).  Each generator returns the text
of a module; ``python -m tools.fit`` writes them and a test fails when a
committed one is stale."""

from pathlib import Path

FITS = Path(__file__).resolve().parent.parent / "addon" / "core" / "fits"


def outputs() -> dict:
    """Every generated data module: path -> text."""
    from . import series
    return {FITS / "erfc.py": series.erfc_module(),
            FITS / "smith_lambda.py": series.smith_lambda_module()}
