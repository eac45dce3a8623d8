# SPDX-License-Identifier: GPL-3.0-or-later
"""The gonioreflectometer's tiles under several lamps (suns, point and spot
lamps), for exact mode with several lights and for the hybrid mode.

:func:`plan_lit` is numpy only: the tiles and pixels of
:func:`..gonio.plan_gonio`, and per lamp the direction toward it and the
irradiance at every pixel (a sun's strength; a point or spot lamp's
intensity / d^2, a spot's cone as Cycles computes it), with every pixel
that any lamp's ray to another tile might shadow left out of the mask.
:meth:`LitScene.reference` is the sum over the lamps of
``addon.reference.shade`` times the irradiance: the expectation, from the
scene's known geometry only.  :func:`build_lit_scene` makes it in Blender
(lamps of radius 0: Cycles treats them as points).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .. import harness as common
from ..harness.geometry import camera_basis, normalize
from . import gonio


@dataclass(frozen=True)
class Lamp:
    """``kind`` 'SUN', 'POINT' or 'SPOT'.  ``direction``: toward a sun, or a
    spot's axis reversed (the lamp's +Z); ``position``: of a point or spot;
    ``strength``: a sun's irradiance (W/m^2) or a point/spot intensity
    (W/sr); ``color``: RGB; a spot's full ``size`` (radians) and ``blend``."""
    kind: str
    direction: tuple = (0.0, 0.0, 1.0)
    position: tuple = (0.0, 0.0, 5.0)
    strength: float = 1.0
    color: tuple = (1.0, 1.0, 1.0)
    size: float = math.radians(45.0)
    blend: float = 0.15


def spot_cone(cos_axis, size, blend):
    """Cycles' spot attenuation (an unscaled lamp): smoothstep((cos - cos
    half) / ((1 - cos half) blend)); a hard edge at blend 0."""
    c = math.cos(0.5 * size)
    width = (1.0 - c) * blend
    if width > 0.0:
        f = np.clip((cos_axis - c) / width, 0.0, 1.0)
    else:
        f = (cos_axis > c).astype(np.float64)
    return f * f * (3.0 - 2.0 * f)


@dataclass
class LitScene:
    gonio: gonio.GonioScene
    lamps: list
    wi: list            # per lamp: (H, W, 3) toward the lamp
    irradiance: list    # per lamp: (H, W, 3) W/m^2 on a plane facing it
    mask: np.ndarray    # inside a tile and shadowed by no tile for any lamp
    scene: object = None
    lamp_objects: list = field(default_factory=list)

    def reference(self, model, **params):
        """Expected image: sum over the lamps of E times addon.reference.shade."""
        from addon import reference

        g, m = self.gonio, self.mask
        out = np.zeros(m.shape + (3,))
        for wi, irr in zip(self.wi, self.irradiance):
            values = np.asarray(reference.shade(model, wi[m], g.wo[m], normal=g.normal[m],
                                                tangent=g.tangent[m], **params), np.float64)
            if values.ndim == 1:
                values = values[:, None]
            out[m] += np.broadcast_to(values, (int(m.sum()), 3)) * irr[m]
        return out

    def footprint_spread(self, model, filter_width=0.01, **params):
        """Per pixel, how much the expected value changes across the
        camera's pixel filter (Cycles jitters the ray within ``filter_width``
        pixels): the largest |change| over the footprint's four corners.
        Point lamps' 1/d^2 and spots' cone edges vary across it; suns do
        not."""
        from addon import reference

        g, m = self.gonio, self.mask
        px = g.ortho_scale / g.resolution[0]
        basis = camera_basis(g.view_dir)
        P0 = g.position[m]
        base = self.reference(model, **params)[m]
        spread = np.zeros_like(base)
        half = 0.5 * filter_width * px
        for du, dv in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            shift = half * (du * basis[:, 0] + dv * basis[:, 1])
            # the ray moves in the camera plane: the hit point slides on the tile
            n = g.normal[m]
            t = np.einsum("j,ij->i", shift, n)
            P = P0 + shift - (t / np.einsum("j,ij->i", g.view_dir, n))[:, None] * g.view_dir
            total = np.zeros_like(base)
            for lamp in self.lamps:
                w, e, _d = lamp_at(lamp, P)
                v = np.asarray(reference.shade(model, w, g.wo[m], normal=n,
                                               tangent=g.tangent[m], **params), np.float64)
                total += (v[:, None] if v.ndim == 1 else v) * e
            spread = np.maximum(spread, np.abs(total - base))
        out = np.zeros(m.shape + (3,))
        out[m] = spread
        return out

    def render(self, path=None):
        return gonio.render(self.gonio, path)


def _shadowed(g, P, own, wi, maxdist):
    """Whether the ray from P along wi (per point) meets another tile (each
    grown by one pixel) before maxdist."""
    px = g.ortho_scale / g.resolution[0]
    half = g.tile_size / 2.0
    N = np.array([t.normal for t in g.tiles])
    U = np.array([t.tangent for t in g.tiles])
    V = np.cross(N, U)
    hit = np.zeros(len(P), dtype=bool)
    for m, cm in enumerate(g.centres):
        denom = wi @ N[m]
        ok = np.abs(denom) > 1e-12
        tt = np.where(ok, ((cm - P) @ N[m]) / np.where(ok, denom, 1.0), -1.0)
        q = P + tt[:, None] * wi - cm
        extent = np.maximum(np.abs(q @ U[m]), np.abs(q @ V[m]))
        hit |= ok & (own != m) & (tt > 1e-9) & (tt < maxdist) & (extent <= half + px)
    return hit


def lamp_at(lamp: Lamp, P):
    """``(wi, irradiance (n, 3), distance)`` of ``lamp`` at points ``P``."""
    color = np.broadcast_to(np.asarray(lamp.color, np.float64), (3,))
    if lamp.kind == "SUN":
        w = np.broadcast_to(normalize(lamp.direction), P.shape)
        e = np.full(len(P), float(lamp.strength))
        dist = np.full(len(P), np.inf)
    else:
        v = np.asarray(lamp.position, np.float64) - P
        dist = np.linalg.norm(v, axis=1)
        w = v / dist[:, None]
        e = lamp.strength / dist ** 2
        if lamp.kind == "SPOT":
            e = e * spot_cone(w @ normalize(lamp.direction), lamp.size, lamp.blend)
    return w, e[:, None] * color, dist


def plan_lit(lamps, *, resolution=48, tiles=None):
    """The scene's per-pixel geometry and, per lamp, wi and irradiance."""
    g = gonio.plan_gonio(light_dir=(0.0, 0.0, 1.0), resolution=resolution, tiles=tiles)
    on = g.inside
    rows, cols = np.nonzero(on)
    P = g.position[rows, cols]
    own = g.tile_index[rows, cols]
    shadow = np.zeros(len(P), dtype=bool)
    wis, irrs = [], []
    for lamp in lamps:
        wi = np.zeros(g.mask.shape + (3,))
        irr = np.zeros(g.mask.shape + (3,))
        w, e, dist = lamp_at(lamp, P)
        wi[rows, cols] = w
        irr[rows, cols] = e
        shadow |= _shadowed(g, P, own, w, dist)
        wis.append(wi)
        irrs.append(irr)
    mask = np.zeros(g.mask.shape, dtype=bool)
    mask[rows, cols] = ~shadow
    return LitScene(g, list(lamps), wis, irrs, mask)


def _matrix(z_axis, position):
    from mathutils import Matrix
    m = np.eye(4)
    m[:3, :3] = camera_basis(z_axis)
    m[:3, 3] = position
    return Matrix(m.tolist())


def add_lamp(scene, lamp: Lamp, name):
    """A Blender lamp of radius 0 (a point) as ``lamp`` describes: a point
    or spot of intensity I has power 4 pi I (Cycles' normalised point)."""
    bpy = common.import_bpy()
    kind = lamp.kind
    data = bpy.data.lights.new(name, kind)
    data.color = tuple(lamp.color)
    if kind == "SUN":
        data.energy = float(lamp.strength)
        data.angle = 0.0
    else:
        data.energy = float(lamp.strength) * 4.0 * math.pi
        data.shadow_soft_size = 0.0
        if kind == "SPOT":
            data.spot_size = float(lamp.size)
            data.spot_blend = float(lamp.blend)
    obj = bpy.data.objects.new(name, data)
    pos = np.asarray(lamp.position, np.float64) if kind != "SUN" \
        else normalize(lamp.direction) * 10.0
    obj.matrix_world = _matrix(lamp.direction, pos)
    scene.collection.objects.link(obj)
    return obj


def move_to_collection(obj, collection):
    """``obj`` taken out of every collection it is in and put in
    ``collection`` (a lamp moved into a collection of the user's)."""
    for coll in list(obj.users_collection):
        coll.objects.unlink(obj)
    collection.objects.link(obj)


def build_lit_scene(material, lamps, *, resolution=48, name="lit"):
    """The tiles with ``material`` under ``lamps``; no sky, direct light."""
    plan = plan_lit(lamps, resolution=resolution)
    g = plan.gonio
    bpy = common.import_bpy()
    scene = common.new_scene(name)
    common.configure_cycles(scene, samples=1, max_bounces=0, filter_width=0.01, osl=True)
    common.set_linear_exr_output(scene, g.resolution)
    common.set_world_background(scene, 0.0)
    camera, _ = common.add_orthographic_camera(scene, g.view_dir, g.ortho_scale)
    mesh = gonio._build_tiles_mesh(name + "_tiles", g.tiles, g.centres, g.tile_size)
    if material is not None:
        material.cycles.emission_sampling = 'NONE'
        mesh.materials.append(material)
    obj = bpy.data.objects.new(name + "_tiles", mesh)
    scene.collection.objects.link(obj)
    g.scene, g.camera, g.tiles_object, g.material = scene, camera, obj, material
    objects = [add_lamp(scene, lamp, f"{name}_lamp{k}") for k, lamp in enumerate(lamps)]
    # the lamps as Blender holds them (float32 matrices): a spot's cone edge
    # turns a 1e-7 change of its axis into 1e-5 of its light
    placed = []
    for lamp, obj in zip(lamps, objects):
        m = np.array(obj.matrix_world, dtype=np.float64)
        placed.append(dataclasses.replace(lamp, direction=tuple(normalize(m[:3, 2])),
                                          position=tuple(m[:3, 3]) if lamp.kind != "SUN"
                                          else lamp.position))
    exact = plan_lit(placed, resolution=resolution)
    plan.wi, plan.irradiance, plan.mask, plan.lamps = (exact.wi, exact.irradiance, exact.mask,
                                                       exact.lamps)
    plan.scene = scene
    plan.lamp_objects = objects
    return plan


# The lamps of the exact-mode checks: three suns and a point lamp; and two
# spots whose cone edges cross the tiles (one soft, one hard).
FOUR_LAMPS = (
    Lamp("SUN", direction=(0.35, 0.25, 0.90), strength=1.0),
    Lamp("SUN", direction=(-0.55, 0.35, 0.76), strength=0.6, color=(1.0, 0.8, 0.6)),
    Lamp("SUN", direction=(0.1, -0.6, 0.79), strength=0.4, color=(0.6, 0.7, 1.0)),
    Lamp("POINT", position=(1.5, -2.0, 6.0), strength=30.0, color=(0.7, 0.8, 1.0)),
)
SPOTS = (
    Lamp("SPOT", position=(-1.0, -1.5, 7.0), direction=(-0.12, -0.2, 0.97),
         strength=40.0, size=math.radians(40.0), blend=0.3),
    Lamp("SPOT", position=(2.0, 1.0, 6.0), direction=(0.3, 0.2, 0.93),
         strength=25.0, size=math.radians(50.0), blend=0.0),
)
