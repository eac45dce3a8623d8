# SPDX-License-Identifier: GPL-3.0-or-later
"""``addon.catalogue``: the public name of :mod:`addon.core.catalogue`."""

from .core.catalogue import *  # noqa: F401,F403
from .core.catalogue import (  # noqa: F401
    ALPHA_MAX, ALPHA_MIN, BETA_MAX, BETA_MIN, DEG, DISTRIBUTIONS, FRESNELS, GEOMETRY_INPUTS,
    LIGHT_INPUTS, MAIN_OUTPUTS, METALS, MODELS, PRESETS, SHADOWINGS, Model, Param, Preset,
    names, resolve,
)
