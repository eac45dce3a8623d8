# SPDX-License-Identifier: GPL-3.0-or-later
"""Registration of every Blender class, menu and handler of the extension.

Kept apart from ``__init__`` so that importing the package never imports bpy:
``__init__.register`` imports this module only when Blender enables the
extension.
"""

from . import ui

_MODULES = (ui,)  # modules exposing register()/unregister(), in order


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()
