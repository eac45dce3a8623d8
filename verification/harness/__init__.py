# SPDX-License-Identifier: GPL-3.0-or-later
"""The measurement harness: a Blender session with throwaway user folders
(:mod:`.session`), the extension zip (:mod:`.package`), Cycles and scene
set-up (:mod:`.blender`), images (:mod:`.images`), comparison
(:mod:`.compare`), the check record (:mod:`.checks`).

The names most scenes use are re-exported here; importing this package
does not import bpy.
"""

from .blender import (  # noqa: F401
    add_orthographic_camera, add_sun, configure_cycles, configure_eevee, eevee_engine,
    empty_material, import_bpy,
    material_uses_osl, new_scene, render_image, render_to_exr, set_linear_exr_output,
    set_world_background,
)
from .compare import aggregate, compare, rel_error_map  # noqa: F401
from .geometry import camera_basis, normalize  # noqa: F401
from .images import read_exr, srgb_encode, temp_path, write_png  # noqa: F401
