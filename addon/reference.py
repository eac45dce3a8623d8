# SPDX-License-Identifier: GPL-3.0-or-later
"""``addon.reference``: the public name of the numpy reference, which lives
in :mod:`addon.core.reference` (see its docstring)."""

from .core.reference import *  # noqa: F401,F403
from .core.reference import __all__, __doc__  # noqa: F401
