# SPDX-License-Identifier: GPL-3.0-or-later
"""Headless Cycles measurement scenes (test code, not shipped in the extension).

- :mod:`test_scenes.gonio`: the virtual gonioreflectometer.  Flat tiles with
  exactly known normals and tangents under one sun lamp, seen by an
  orthographic camera; every masked pixel equals ``f_r(wi, wo) * max(0, N.wi)``.
- :mod:`test_scenes.furnace`: the white furnace (uniform unit environment);
  a pixel equals the directional albedo ``int f_r cos dwi`` of the material.
- :mod:`test_scenes.common`: bpy start-up, Cycles settings, EXR I/O and the
  render-versus-expectation comparison.

Nothing here imports bpy at module import; :func:`common.import_bpy` does it,
after preparing the process environment.
"""
