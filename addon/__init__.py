# SPDX-License-Identifier: GPL-3.0-or-later
"""Reflection Models: the classic reflection models of CS348B Lecture 11 as
shader nodes for Cycles and EEVEE.

The package has two layers.  ``catalogue`` and ``reference`` need numpy only
(no ``bpy``); everything that touches Blender lives in modules imported lazily
from :func:`register`, so ``import addon.reference`` works outside Blender.
"""


def register():
    from . import blender_registration
    blender_registration.register()


def unregister():
    from . import blender_registration
    blender_registration.unregister()
