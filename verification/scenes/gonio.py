# SPDX-License-Identifier: GPL-3.0-or-later
"""The virtual gonioreflectometer: a deterministic direct-light scene whose
every measured pixel equals ``strength * f_r(wi, wo) * max(0, N.wi)``.

Set-up
------
- An orthographic camera looks along ``-view_dir``; so ``wo = view_dir`` for
  every pixel.  A SUN lamp of angle 0 and strength 1 lies along ``light_dir``
  (``wi``).  Cycles on the CPU, 1 sample, no bounces, pixel filter 0.01 px
  (the camera ray goes through the pixel centre), no denoising, the world
  switched off, view transform Standard; the float32 EXR holds linear
  radiance.
- The geometry is a grid of flat square tiles, one per cell of the image
  plane, each with a known normal and a known tangent (the quad's U edge
  direction, which is also the UV-derived tangent: the tile's UVs run 0..1
  along U and along V = N x U).  Tiles fill at most 70 % of their cell so
  their orthographic projections never overlap.
- For every pixel the geometry is computed analytically (never from the
  render): the tile it sees, whether its centre lies at least ``erode`` pixels
  inside the tile's projected outline, whether another tile shadows the sun
  at the hit point, and the per-pixel ``normal``, ``tangent``, ``wi``,
  ``wo`` and hit ``position``.

Because every pixel shares ``wi`` and ``wo``, the angle between L and
H = normalize(L + E) is the same over the whole image: a Fresnel term is
measured at one angle per render.  :func:`light_for_half_angle` picks the
light for a given ``theta_d``; sweep it to cover the Fresnel curve.

Cost (2 cores, 25 tiles, 1 sample; the render call): 64x64 in 7-14 ms and
256x256 in 56-83 ms with a native BSDF, 74 ms and 102 ms through an OSL
Script node; building the scene takes 16 ms and 100 ms.  Agreement with
formulas is float32 rounding: 1e-6 to 2e-5 relative (docs/cycles-closures.md).

Typical use::

    g = build_gonio_scene(material, light_dir=(0.3, 0.2, 0.93), resolution=128)
    img = render(g)                      # (H, W, 3) float32, row 0 = top
    exp = g.expected(lambda wi, wo, n, t: c / np.pi * np.maximum(0, (n * wi).sum(-1)))
    stats = compare(img, exp, g.mask)    # max_rel_error, rms_rel_error, ...
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import harness as common
from ..harness import camera_basis, compare, normalize  # noqa: F401  (re-exported)

DEFAULT_TILTS_DEG = (0.0, 20.0, 40.0, 60.0, 72.0)
DEFAULT_AZIMUTHS_DEG = (0.0, 60.0, 120.0, 180.0, 240.0, 300.0)
MAX_FILL = 0.7  # < 1/sqrt(2): a tilted square's projection stays inside its cell


@dataclass(frozen=True)
class Tile:
    """A flat square tile: unit ``normal`` and unit ``tangent`` (its U edge,
    perpendicular to the normal), both in world space."""
    normal: tuple
    tangent: tuple


def _rotate(v, axis, angle):
    """Rodrigues rotation of vector ``v`` about unit ``axis`` by ``angle``."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1.0 - c)


def make_tile(normal, tangent):
    """A :class:`Tile` with ``tangent`` made perpendicular to ``normal``
    (Gram-Schmidt) and both normalised."""
    n = normalize(normal)
    t = np.asarray(tangent, dtype=np.float64)
    t = normalize(t - n * np.dot(n, t))
    return Tile(tuple(float(x) for x in n), tuple(float(x) for x in t))


def hemisphere_tiles(tilts_deg=DEFAULT_TILTS_DEG, azimuths_deg=DEFAULT_AZIMUTHS_DEG, *,
                     view_dir=(0.0, 0.0, 1.0), up_hint=None, twist_deg=0.0):
    """Tiles whose normals are tilted from ``view_dir`` by each angle of
    ``tilts_deg`` toward each azimuth of ``azimuths_deg`` (azimuth 0 = camera
    right, 90 = camera up); a tilt of 0 gives one tile only.

    The tangent is the camera's right axis carried along by the smallest
    rotation taking ``view_dir`` to the normal, then turned by ``twist_deg``
    about the normal (right-hand rule).  Tilts must stay below 90 degrees
    (the tile must face the camera).
    """
    basis = camera_basis(view_dir, up_hint)
    right, w = basis[:, 0], basis[:, 2]
    tiles = []
    for tilt in tilts_deg:
        if not 0.0 <= tilt < 90.0:
            raise ValueError(f"tilt {tilt} outside [0, 90)")
        for az in (azimuths_deg if tilt > 0 else azimuths_deg[:1]):
            t, a = math.radians(tilt), math.radians(az)
            n = basis @ np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])
            tangent = right.copy()
            if tilt > 0:
                axis = normalize(np.cross(w, n))
                tangent = _rotate(tangent, axis, t)
            if twist_deg:
                tangent = _rotate(tangent, n, math.radians(twist_deg))
            tiles.append(make_tile(n, tangent))
    return tiles


def light_for_half_angle(theta_d_deg, azimuth_deg=0.0, *, view_dir=(0.0, 0.0, 1.0),
                         up_hint=None):
    """The light direction making ``angle(L, H) = angle(E, H) = theta_d`` with
    the camera direction ``view_dir``: ``L`` lies ``2 theta_d`` away from
    ``view_dir``, toward ``azimuth_deg`` (0 = camera right, 90 = camera up).
    ``theta_d`` must lie in [0, 90) degrees."""
    if not 0.0 <= theta_d_deg < 90.0:
        raise ValueError("theta_d must lie in [0, 90) degrees")
    basis = camera_basis(view_dir, up_hint)
    t, a = math.radians(2.0 * theta_d_deg), math.radians(azimuth_deg)
    return basis @ np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


@dataclass
class GonioScene:
    """A built gonioreflectometer scene and its per-pixel geometry.

    Arrays are ``(H, W)`` or ``(H, W, 3)``, row 0 = top of the image, in the
    order :func:`render` returns pixels.  Outside any tile, vectors are 0 and
    ``tile_index`` is -1.

    - ``inside``: pixel centre at least ``erode`` pixels inside a tile's
      projected outline.
    - ``shadowed``: the sun ray from the hit point meets another tile
      (each tile grown by one pixel, conservatively); ``umbra``: it meets a
      tile shrunk by one pixel (surely in shadow).
    - ``mask = inside & ~shadowed``: the pixels to measure.  It includes
      pixels with ``N.wi <= 0`` (they must render 0); ``lit`` excludes them.
    - ``normal``, ``tangent``: the tile's unit vectors; ``wi``, ``wo``: unit
      directions to the sun and to the camera; ``position``: world-space hit
      point; ``cos_i = N.wi``, ``cos_o = N.wo``.
    """
    tiles: list
    light_dir: np.ndarray
    view_dir: np.ndarray
    strength: float
    resolution: tuple
    ortho_scale: float
    tile_size: float
    erode: float
    tile_index: np.ndarray
    inside: np.ndarray
    shadowed: np.ndarray
    umbra: np.ndarray
    mask: np.ndarray
    lit: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    wi: np.ndarray
    wo: np.ndarray
    position: np.ndarray
    cos_i: np.ndarray
    cos_o: np.ndarray
    centres: list = field(default_factory=list)
    scene: object = None
    camera: object = None
    sun: object = None
    tiles_object: object = None
    material: object = None
    last_render_seconds: float = field(default=float("nan"))

    def expected(self, shade):
        """Expected image ``(H, W, 3)`` from ``shade(wi, wo, normal, tangent)``,
        which receives ``(n, 3)`` arrays of the masked pixels and returns the
        radiance under unit irradiance, ``f_r * max(0, N.wi)``, as ``(n,)``
        (grey), ``(n, 3)`` or anything broadcasting to it (e.g. a constant
        ``(3,)`` colour); multiplied by the sun strength; 0 outside the mask."""
        m = self.mask
        n = int(m.sum())
        values = np.asarray(shade(self.wi[m], self.wo[m], self.normal[m], self.tangent[m]),
                            dtype=np.float64)
        if values.ndim == 1 and values.shape[0] == n:
            values = values[:, None]  # one grey value per pixel
        out = np.zeros(self.mask.shape + (3,))
        out[m] = np.broadcast_to(values, (n, 3)) * self.strength
        return out

    def reference(self, model, **params):
        """Expected image from ``addon.reference.shade(model, wi, wo,
        normal=..., tangent=..., **params)``."""
        from addon import reference

        return self.expected(lambda wi, wo, n, t: reference.shade(
            model, wi, wo, normal=n, tangent=t, **params))

    def white_peak(self):
        """The brightest radiance a white Lambertian surface shows on the
        masked pixels (``strength * max cos_i / pi``): the scale of an
        expectation that is black everywhere."""
        cos_i = np.clip(self.cos_i[self.mask], 0.0, None)
        return self.strength * max(float(cos_i.max()), 1e-6) / math.pi

    def mirror_peak(self, model, max_angle_deg=70.0, **params):
        """The model's value with the light in each masked pixel's mirror
        direction (the peak of a lobe around it), largest over the pixels
        whose view is within ``max_angle_deg`` of the normal: the scale a
        fitted mixture's bound refers to, which a narrow lobe's gonio image
        may not contain (no pixel at the mirror direction)."""
        from addon import reference

        m = self.mask & (self.cos_o >= math.cos(math.radians(max_angle_deg)))
        if not m.any():
            return 0.0
        n, wo = self.normal[m], self.wo[m]
        wi = 2.0 * np.sum(n * wo, -1, keepdims=True) * n - wo
        values = reference.shade(model, wi, wo, normal=n, tangent=self.tangent[m], **params)
        return float(np.max(values)) * self.strength

    def render(self, path=None):
        """Shorthand for :func:`render`."""
        return render(self, path)


def _pixel_plane(resolution, ortho_scale):
    """Camera-plane coordinates (x right, y up) of every pixel centre."""
    w, h = resolution
    p = ortho_scale / w
    xs = (np.arange(w) + 0.5 - w / 2.0) * p
    ys = (h / 2.0 - np.arange(h) - 0.5) * p
    return np.meshgrid(xs, ys)  # each (H, W)


def _tile_frames(tiles):
    n = np.array([t.normal for t in tiles], dtype=np.float64)
    u = np.array([t.tangent for t in tiles], dtype=np.float64)
    v = np.cross(n, u)
    return n, u, v


def _span(coords, n):
    """``(start, stop)`` of the pixels (centres at index + 0.5) that
    continuous pixel coordinates from min(coords) to max(coords) can reach,
    a pixel wider each side, within 0..n."""
    lo, hi = min(coords), max(coords)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return 0, n
    return max(0, math.floor(lo) - 1), min(n, math.ceil(hi) + 1)


def _compute_geometry(tiles, centres, size, basis, light_dir, resolution, ortho_scale, erode):
    w, h = resolution
    px = ortho_scale / w
    right, up, wo = basis[:, 0], basis[:, 1], basis[:, 2]
    wi = normalize(light_dir)
    X, Y = _pixel_plane(resolution, ortho_scale)
    plane = X[..., None] * right + Y[..., None] * up  # (H, W, 3), depth 0
    U_pix = X / px + w / 2.0  # continuous pixel coordinates of the centres
    V_pix = h / 2.0 - Y / px
    N, U, V = _tile_frames(tiles)
    half = size / 2.0

    tile_index = np.full((h, w), -1, dtype=np.int64)
    inside = np.zeros((h, w), dtype=bool)
    depths = []
    for k, c in enumerate(centres):
        corners = [c + sa * half * U[k] + sb * half * V[k]
                   for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        depths += [float(np.dot(p, wo)) for p in corners]
        q = np.array([[np.dot(p, right) / px + w / 2.0, h / 2.0 - np.dot(p, up) / px]
                      for p in corners])
        area = sum(q[i, 0] * q[(i + 1) % 4, 1] - q[(i + 1) % 4, 0] * q[i, 1] for i in range(4))
        orient = 1.0 if area > 0 else -1.0
        # the pixels whose centres (column + 0.5, row + 0.5) can lie in the
        # quad: its bounding box, a pixel wider (the same test, on fewer pixels)
        win = (slice(*_span(q[:, 1], h)), slice(*_span(q[:, 0], w)))
        dmin = np.full(U_pix[win].shape, np.inf)
        for i in range(4):
            a, b = q[i], q[(i + 1) % 4]
            e = b - a
            d = orient * (e[0] * (V_pix[win] - a[1]) - e[1] * (U_pix[win] - a[0])) \
                / np.hypot(*e)
            dmin = np.minimum(dmin, d)
        covered = dmin >= 0.0
        if np.any(covered & (tile_index[win] >= 0)):
            raise AssertionError("tile projections overlap")
        tile_index[win][covered] = k
        inside[win] |= dmin >= erode

    normal = np.zeros((h, w, 3))
    tangent = np.zeros((h, w, 3))
    position = np.zeros((h, w, 3))
    on = tile_index >= 0
    k = tile_index[on]
    normal[on] = N[k]
    tangent[on] = U[k]
    # orthographic ray from the pixel centre along -wo onto the tile's plane
    c = np.asarray(centres)[k]
    t = np.einsum("ij,ij->i", plane[on] - c, N[k]) / (N[k] @ wo)
    position[on] = plane[on] - t[:, None] * wo

    # shadows: the ray toward the sun from each inside pixel against every
    # other tile, grown by one pixel so that edge pixels count as shadowed
    # (umbra: the same against tiles shrunk by one pixel: surely in shadow)
    shadowed = np.zeros((h, w), dtype=bool)
    umbra = np.zeros((h, w), dtype=bool)
    # Only pixels near tile m can be shadowed by it: the ray from a pixel's
    # point P meets m's plane at Q, a depth (along wo) of at most ``spread``
    # from P, so across the view at most reach = spread |wi x wo| / |wi . wo|
    # from P; Q counts within (half + px) sqrt 2 of m's centre.  A window of
    # the image that wide (and a pixel more) about the centre holds every
    # pixel the test below could find (all of them with a light in the
    # image plane).
    cos_light = float(np.dot(wi, wo))
    spread = max(depths) - min(depths)
    if abs(cos_light) > 1e-6:
        reach = spread * math.sqrt(max(0.0, 1.0 - cos_light ** 2)) / abs(cos_light)
        radius = (reach + (half + px) * math.sqrt(2.0)) / px + 1.0
    else:
        radius = math.inf
    for m, cm in enumerate(centres):
        denom = float(np.dot(wi, N[m]))
        if abs(denom) < 1e-12:
            continue
        cu, cv = np.dot(cm, right) / px + w / 2.0, h / 2.0 - np.dot(cm, up) / px
        win = (slice(*_span((cv - radius, cv + radius), h)),
               slice(*_span((cu - radius, cu + radius), w)))
        sel = inside[win]
        P = position[win][sel]
        if not len(P):
            continue
        tt = ((cm - P) @ N[m]) / denom
        q = P + tt[:, None] * wi - cm
        extent = np.maximum(np.abs(q @ U[m]), np.abs(q @ V[m]))
        ahead = (tile_index[win][sel] != m) & (tt > 1e-9)
        shadowed[win][sel] |= ahead & (extent <= half + px)
        umbra[win][sel] |= ahead & (extent <= half - px)

    mask = inside & ~shadowed
    wi_img = np.where(on[..., None], wi, 0.0)
    wo_img = np.where(on[..., None], wo, 0.0)
    cos_i = np.einsum("ijk,ijk->ij", normal, wi_img)
    cos_o = np.einsum("ijk,ijk->ij", normal, wo_img)
    return dict(tile_index=tile_index, inside=inside, shadowed=shadowed, umbra=umbra, mask=mask,
                lit=mask & (cos_i > 0), normal=normal, tangent=tangent, wi=wi_img,
                wo=wo_img, position=position, cos_i=cos_i, cos_o=cos_o)


def _build_tiles_mesh(name, tiles, centres, size):
    bpy = common.import_bpy()
    N, U, V = _tile_frames(tiles)
    half = size / 2.0
    verts, faces = [], []
    for k, c in enumerate(centres):
        for sa, sb in ((-1, -1), (1, -1), (1, 1), (-1, 1)):  # counter-clockwise about N
            verts.append(tuple(c + sa * half * U[k] + sb * half * V[k]))
        faces.append((4 * k, 4 * k + 1, 4 * k + 2, 4 * k + 3))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    uv = mesh.uv_layers.new(name="UVMap")
    corner_uv = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
    for poly in mesh.polygons:
        poly.use_smooth = False
        for j, li in enumerate(poly.loop_indices):
            uv.data[li].uv = corner_uv[j]
    mesh.update()
    # Blender's own face normals must agree with the tiles' normals
    got = np.array([p.normal[:] for p in mesh.polygons])
    if np.max(np.abs(got - N)) > 1e-5:
        raise AssertionError("tile winding does not match the requested normals")
    return mesh


def plan_gonio(*, light_dir, view_dir=(0.0, 0.0, 1.0), tiles=None, resolution=64,
               fill=0.7, erode=1.0, strength=1.0, up_hint=None, columns=None):
    """The layout and per-pixel geometry of a gonioreflectometer scene,
    without Blender (numpy only): a :class:`GonioScene` whose Blender fields
    (``scene``, ``camera``, ...) are None.  Arguments as for
    :func:`build_gonio_scene`."""
    if not 0.0 < fill <= MAX_FILL:
        raise ValueError(f"fill must lie in (0, {MAX_FILL}]")
    if isinstance(resolution, (int, np.integer)):
        resolution = (resolution, resolution)
    resolution = (int(resolution[0]), int(resolution[1]))
    light_dir = normalize(light_dir)
    basis = camera_basis(view_dir, up_hint)
    view_dir = basis[:, 2]
    if tiles is None:
        tiles = hemisphere_tiles(view_dir=view_dir, up_hint=up_hint)
    tiles = [make_tile(t.normal, t.tangent) for t in tiles]
    for t in tiles:
        if np.dot(t.normal, view_dir) <= 1e-6:
            raise ValueError(f"tile normal {t.normal} does not face the camera")

    w, h = resolution
    nx = int(columns) if columns else math.ceil(math.sqrt(len(tiles)))
    ny = math.ceil(len(tiles) / nx)
    ortho_scale = float(max(nx, ny * w / h))  # cells of side 1
    right, up = basis[:, 0], basis[:, 1]
    centres = [((k % nx) - (nx - 1) / 2.0) * right + ((ny - 1) / 2.0 - (k // nx)) * up
               for k in range(len(tiles))]
    geo = _compute_geometry(tiles, centres, fill, basis, light_dir, resolution,
                            ortho_scale, erode)
    return GonioScene(tiles=tiles, light_dir=light_dir, view_dir=view_dir,
                      strength=float(strength), resolution=resolution,
                      ortho_scale=ortho_scale, tile_size=fill, erode=float(erode),
                      centres=centres, **geo)


def build_gonio_scene(material, *, light_dir, view_dir=(0.0, 0.0, 1.0), tiles=None,
                      resolution=64, fill=0.7, erode=1.0, strength=1.0, osl=None,
                      up_hint=None, name="gonio", columns=None):
    """Build the gonioreflectometer scene for ``material``.

    - ``light_dir``: direction toward the sun (wi), world space.
    - ``view_dir``: direction toward the camera (wo), world space; the
      camera's up is ``up_hint`` (default world +Y) projected on the image
      plane, so with the default view the image x/y are world x/y.
    - ``tiles``: list of :class:`Tile` (default :func:`hemisphere_tiles` around
      ``view_dir``: 25 tiles, tilts 0-72 degrees, 6 azimuths), laid out
      row by row from the top left, ``columns`` to a row (default: as many
      as make the grid square).  Each must face the camera.
    - ``resolution``: int (square) or ``(W, H)`` in pixels.
    - ``fill``: tile side / cell side (at most 0.7); ``erode``: pixels kept
      between a measured pixel centre and a tile edge.
    - ``strength``: sun irradiance.  ``osl``: use the OSL shading system
      (default: when the material holds a Script node).

    The material's ``cycles.emission_sampling`` is set to 'NONE' (a tile must
    not be sampled as a light: that would add noise to the 1-sample render).
    Each call makes a new Blender scene named after ``name``.
    Returns a :class:`GonioScene`.
    """
    g = plan_gonio(light_dir=light_dir, view_dir=view_dir, tiles=tiles,
                   resolution=resolution, fill=fill, erode=erode, strength=strength,
                   up_hint=up_hint, columns=columns)
    bpy = common.import_bpy()
    scene = common.new_scene(name)
    if osl is None:
        osl = common.material_uses_osl(material)
    common.configure_cycles(scene, samples=1, max_bounces=0, filter_width=0.01, osl=osl)
    common.set_linear_exr_output(scene, g.resolution)
    common.set_world_background(scene, 0.0)
    camera, _ = common.add_orthographic_camera(scene, g.view_dir, g.ortho_scale,
                                               up_hint=up_hint)
    sun = common.add_sun(scene, g.light_dir, g.strength)
    mesh = _build_tiles_mesh(name + "_tiles", g.tiles, g.centres, g.tile_size)
    if material is not None:
        material.cycles.emission_sampling = 'NONE'
        mesh.materials.append(material)
    obj = bpy.data.objects.new(name + "_tiles", mesh)
    scene.collection.objects.link(obj)
    g.scene, g.camera, g.sun, g.tiles_object, g.material = scene, camera, sun, obj, material
    return g


def render(gonio, path=None):
    """Render ``gonio`` (a :class:`GonioScene`) to the float32 EXR ``path``
    (default: a temporary file, removed after reading) and return its RGB as
    ``(H, W, 3)`` float32, row 0 = top, matching the geometry arrays.  The
    render's wall time is stored in ``gonio.last_render_seconds``."""
    if path is None:
        img, gonio.last_render_seconds = common.render_image(gonio.scene, "gonio_")
    else:
        gonio.last_render_seconds = common.render_to_exr(gonio.scene, path)
        img = common.read_exr(path, 3)
    if img.shape[:2] != gonio.mask.shape:
        raise AssertionError(f"render size {img.shape[:2]} != geometry {gonio.mask.shape}")
    return img
