# SPDX-License-Identifier: GPL-3.0-or-later
"""Portability: a .blend made with the extension renders the same without it.

- Every model and preset of the catalogue, in both modes (path traced: the
  BSDF output; exact: the Direct output, its light bound to the sun by
  simple-expression drivers), one material per tile of a small
  gonioreflectometer, built through the installed extension's API.  The
  file is saved and rendered again in a fresh Python process with no
  extension installed (``tools.bpy_env.render_in_fresh_process``): the two
  renders must be bit-identical.  The node groups hold internal Script nodes
  (OSL source in Text datablocks), so nothing of the extension is needed.
  Both with Open Shading Language on (the groups' OSL shaders) and off
  (their native nodes: Cycles drops Script nodes, and the groups switch),
  and in EEVEE (the native nodes too).
- With OSL off every group renders and nothing warns; a node forced to the
  OSL backend renders black there, and the extension's load and render
  handlers log a clear warning instead of leaving it silent.  (Without the
  extension installed nothing can warn: docs/compatibility.md.)
"""

import importlib
import logging

import numpy as np
import pytest

from addon import catalogue
from verification import harness as common
from verification.scenes import gonio
from verification.harness import session as bpy_env

MODES = ("path_traced", "exact")
LIGHT = gonio.normalize((0.35, 0.2, 0.9))
RES = 32


def _ext(module_name, sub):
    return importlib.import_module(f"{module_name}.{sub}")


def _material(bpy, name):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True  # Blender < 5.0
    return mat


def build_every_model(bpy, api, name="portability"):
    """One tile per (model, mode); returns the GonioScene and the cases."""
    cases = [(model, mode) for model in catalogue.names() for mode in MODES]
    # normals around the half vector, so that narrow lobes light their tile
    half = gonio.normalize(LIGHT + np.array([0.0, 0.0, 1.0]))
    tiles = gonio.hemisphere_tiles((0.0, 4.0, 9.0, 16.0), (0.0, 72.0, 144.0, 216.0, 288.0),
                                   view_dir=half)
    assert len(tiles) >= len(cases)
    g = gonio.build_gonio_scene(None, light_dir=LIGHT, resolution=RES, tiles=tiles[:len(cases)],
                                osl=True, name=name)
    mesh = g.tiles_object.data
    for model, mode in cases:
        mat = _material(bpy, f"{model}_{mode}")
        node = api.add_model(mat, model, mode=mode)
        if mode == "exact":
            api.bind_light(node, g.sun)
        mat.cycles.emission_sampling = 'NONE'
        mesh.materials.append(mat)
    mesh.polygons.foreach_set("material_index", np.arange(len(cases), dtype=np.int32))
    mesh.update()
    return g, cases


@pytest.mark.parametrize("engine", ["osl_on", "osl_off", "eevee"])
def test_saved_file_renders_identically_without_the_extension(bpy, installed_extension,
                                                              tmp_path, engine):
    """With OSL on the groups render their OSL shaders, with it off and in
    EEVEE their native nodes; either way the saved file renders
    bit-identically in a Blender without the extension."""
    api = _ext(installed_extension, "api")
    g, cases = build_every_model(bpy, api, name=f"portability_{engine}")
    if engine == "eevee":
        common.configure_eevee(g.scene)
    else:
        g.scene.cycles.shading_system = engine == "osl_on"
    assert api.rendering_backend(g.scene)[0] == ("osl" if engine == "osl_on" else "native")
    here = g.render(str(tmp_path / "authoring.exr"))
    assert np.isfinite(here).all()
    # the comparison is not black on black
    black = [case for k, case in enumerate(cases) if not here[g.lit & (g.tile_index == k)].any()]
    print("black tiles:", black)
    assert not black, black

    blend = tmp_path / "every_model.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    out = tmp_path / "fresh.exr"
    report = bpy_env.render_in_fresh_process(blend, out, scene=g.scene.name)
    assert not any(bpy_env.EXTENSION_ID in a for a in report["addons"]), report["addons"]
    there = common.read_exr(out, 3)
    print(f"fresh process: Blender {report['blender']}, render {report['seconds']:.2f} s")
    diff = np.abs(there.astype(np.float64) - here)
    bad = [f"{cases[k]}: max |diff| {diff[g.tile_index == k].max():.3g}"
           for k in range(len(cases)) if np.any(diff[g.tile_index == k] > 0)]
    assert np.array_equal(there, here), "\n".join(bad)


def _warnings(caplog, text):
    return [r.getMessage() for r in caplog.records
            if r.levelno >= logging.WARNING and text in r.getMessage()]


def test_osl_off_renders_native_nodes_and_warns_only_for_nodes_forced_to_osl(
        bpy, installed_extension, tmp_path, caplog):
    api = _ext(installed_extension, "api")
    ui = _ext(installed_extension, "ui")
    g, cases = build_every_model(bpy, api, name="osl_off")
    g.scene.cycles.shading_system = False

    with caplog.at_level(logging.WARNING):
        img = g.render()
    # every tile renders (native nodes), and nothing needs a warning
    black = [case for k, case in enumerate(cases) if not img[g.lit & (g.tile_index == k)].any()]
    assert not black, black
    assert not _warnings(caplog, "Reflection Models"), caplog.text

    # a node forced to OSL renders black there, and the render handler says
    # why, naming the scene
    mat = g.tiles_object.data.materials[0]
    node = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeGroup")
    api.set_params(node, backend="osl")
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        img = g.render()
    assert np.all(img[g.tile_index == 0] == 0.0)
    assert img[g.lit & (g.tile_index == 1)].any()
    found = _warnings(caplog, ui.OSL_OFF_WARNING)
    assert found and any(repr(g.scene.name) in m for m in found), caplog.text

    blend = tmp_path / "osl_off.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    caplog.clear()
    try:
        with caplog.at_level(logging.WARNING):
            bpy.ops.wm.open_mainfile(filepath=str(blend), load_ui=False)
        assert _warnings(caplog, ui.OSL_OFF_WARNING), caplog.text  # the load handler
        # with OSL on, neither handler complains
        scene = bpy.data.scenes["osl_off"]
        scene.cycles.shading_system = True
        caplog.clear()
        with caplog.at_level(logging.WARNING):
            ui.on_load_post()
            ui.on_render_init(scene)
        assert not _warnings(caplog, "Reflection Models"), caplog.text
    finally:
        bpy_env.reset_scene()
