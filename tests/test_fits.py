# SPDX-License-Identifier: GPL-3.0-or-later
"""The generated data of addon/core/fits: up to date with its generator, and
the reference's special functions it feeds are as accurate as stated."""

import math
import re

import numpy as np
import pytest

import fitting
from addon import reference as R


NUMBER = re.compile(r"-?\d+\.\d*(?:e[-+]?\d+)?")


@pytest.mark.parametrize("path", sorted(fitting.outputs()), ids=lambda p: p.name)
def test_generated_data_is_up_to_date(path):
    committed, fresh = path.read_text(), fitting.outputs()[path]
    assert NUMBER.sub("#", committed) == NUMBER.sub("#", fresh), "run: python -m tools.fit"
    a = [float(x) for x in NUMBER.findall(committed)]
    b = [float(x) for x in NUMBER.findall(fresh)]
    # numpy versions differ in the last digits of quadrature nodes (eigenvalues): 1e-10
    assert a == pytest.approx(b, rel=1e-10, abs=1e-15), "run: python -m tools.fit"


def test_erfc_is_double_precision():
    """Against the standard library's erfc (itself within a few ulps): 1e-15
    relative, over the whole range where erfc is a normal double."""
    x = np.concatenate([np.linspace(-6, 26, 20001), [0.0, 0.5, 4.0, -0.5, -4.0]])
    want = np.array([math.erfc(v) for v in x])
    got = R.erfc(x)
    assert np.max(np.abs(got - want) / want) < 1.5e-15
    assert R.erfc(np.inf) == 0.0 and R.erfc(-np.inf) == 2.0 and np.isnan(R.erfc(np.nan))
    e = np.linspace(-3, 3, 601)
    assert np.max(np.abs(R.erf(e) - np.array([math.erf(v) for v in e]))) < 2e-16 * 4


def test_gaussian_norm_series_matches_the_quadrature():
    """The series the shaders use for the Gaussian normalisation, against the
    reference's quadrature: 5e-9 relative (float32 is 6e-8)."""
    from addon.core.fits import smith_lambda as S
    beta = np.linspace(S.BETA_MIN, S.BETA_MAX, 2001)
    t = 2 * (beta - S.BETA_MIN) / (S.BETA_MAX - S.BETA_MIN) - 1
    c2 = R.gaussian_c2_from_beta(beta)
    series = c2 * c2 / math.pi * np.exp(np.polynomial.chebyshev.chebval(t, S.GAUSSIAN_NORM))
    assert np.max(np.abs(series / R.gaussian_norm(beta) - 1)) < 5e-9


def test_the_shaders_power_form_of_every_weight_series_is_the_series():
    """The shaders sum each fitted weight series in powers of the view
    variable (Horner's rule); in float32 it must be the committed Chebyshev
    series within 2e-5 of the sum of the series' |coefficients| (float32
    rounding of the powers' coefficients, which sum to at most 75 times the
    series'), at every width node, member and view."""
    from addon.core.fits import mixtures as data
    from addon.core.formulas.mixtures import power_coefficients

    u = np.linspace(-1.0, 1.0, 41)
    for key, d in data.FITS.items():
        w = np.array(d["weights"])  # (n_width, K, n_view)
        P = np.array(power_coefficients(w.shape[2]))
        a = np.einsum("jm,nkm->nkj", P, w).astype(np.float32)
        horner = np.zeros(a.shape[:2] + u.shape, np.float32)
        for j in range(a.shape[2] - 1, -1, -1):
            horner = horner * u.astype(np.float32) + a[..., j:j + 1]
        exact = np.polynomial.chebyshev.chebval(u, np.moveaxis(w, 2, 0))
        scale = np.abs(w).sum(axis=2, keepdims=True) + 1e-30
        assert np.max(np.abs(horner - exact) / scale) <= 2e-5, key
