# SPDX-License-Identifier: GPL-3.0-or-later
"""The white furnace: a sphere with the material inside a uniform environment
of radiance ``environment`` (default 1), seen by an orthographic camera.

The sphere is convex, so every ray leaving it sees the environment: a pixel
equals ``environment * albedo(wo)``, the directional albedo
``int f_r(wi, wo) cos(theta_i) dwi`` at the pixel's view angle.  An
energy-conserving material renders <= environment everywhere (a Diffuse BSDF
of colour c renders c).  The result is Monte Carlo: use enough samples and
average over pixels (:meth:`FurnaceScene.mean`, :meth:`albedo_by_angle`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import harness as common
from ..harness import camera_basis, normalize


@dataclass
class FurnaceScene:
    """A built furnace scene and its per-pixel geometry (row 0 = top).

    ``mask``: pixel centres at least ``erode`` pixels inside the sphere's
    outline; ``normal``: the analytic sphere normal there (0 elsewhere);
    ``cos_o = N.wo``; ``wo``: the direction to the camera."""
    scene: object
    sphere: object
    material: object
    view_dir: np.ndarray
    environment: float
    resolution: tuple
    mask: np.ndarray
    normal: np.ndarray
    cos_o: np.ndarray
    wo: np.ndarray
    last_render_seconds: float = field(default=float("nan"))

    def mean(self, image):
        """Mean radiance per channel over the masked pixels, divided by the
        environment radiance (= the albedo averaged over the disc)."""
        return np.asarray(image)[self.mask][:, :3].mean(axis=0) / self.environment

    def albedo_by_angle(self, image, bins=8):
        """Albedo per channel averaged in ``bins`` equal bins of ``cos_o``
        over (0, 1]: returns ``(cos_centres, albedo (bins, 3), counts)``;
        empty bins hold NaN."""
        img = np.asarray(image)[..., :3] / self.environment
        edges = np.linspace(0.0, 1.0, bins + 1)
        c = self.cos_o[self.mask]
        v = img[self.mask]
        idx = np.clip(np.digitize(c, edges) - 1, 0, bins - 1)
        out = np.full((bins, 3), np.nan)
        counts = np.bincount(idx, minlength=bins)
        for b in range(bins):
            if counts[b]:
                out[b] = v[idx == b].mean(axis=0)
        return 0.5 * (edges[1:] + edges[:-1]), out, counts

    def render(self, path=None):
        """Shorthand for :func:`render`."""
        return render(self, path)


def uv_sphere_mesh(name, segments, *, uvs=False):
    """A smooth UV sphere of radius 1 with ``segments`` around (and a UV map
    when ``uvs``)."""
    bpy = common.import_bpy()
    import bmesh

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    try:
        kwargs = dict(u_segments=segments, v_segments=max(3, segments // 2))
        if uvs:
            kwargs["calc_uvs"] = True
        try:
            bmesh.ops.create_uvsphere(bm, radius=1.0, **kwargs)
        except TypeError:  # older argument name
            bmesh.ops.create_uvsphere(bm, diameter=1.0, **kwargs)
        for f in bm.faces:
            f.smooth = True
        bm.to_mesh(mesh)
    finally:
        bm.free()
    return mesh


def build_furnace_scene(material, *, view_dir=(0.0, 0.0, 1.0), resolution=128, samples=64,
                        max_bounces=16, environment=1.0, segments=128, erode=1.5,
                        osl=None, up_hint=None, name="furnace"):
    """Build the furnace for ``material``: a smooth UV sphere of radius 1
    (``segments`` around) at the origin, an orthographic camera along
    ``view_dir`` framing it with a 10 % margin, a uniform world of radiance
    ``environment``, ``samples`` per pixel and ``max_bounces`` (every bounce
    limit).  ``erode`` pixels are kept between a measured pixel centre and the
    outline (the tessellated silhouette differs from the circle by about
    ``1 - cos(pi/segments)``).  The material's emission sampling is set to
    'NONE'.  Returns a :class:`FurnaceScene`."""
    if isinstance(resolution, int):
        resolution = (resolution, resolution)
    w, h = int(resolution[0]), int(resolution[1])
    basis = camera_basis(view_dir, up_hint)
    view_dir = basis[:, 2]
    ortho_scale = 2.2 * max(1.0, w / h)

    bpy = common.import_bpy()
    scene = common.new_scene(name)
    if osl is None:
        osl = common.material_uses_osl(material)
    common.configure_cycles(scene, samples=samples, max_bounces=max_bounces,
                            filter_width=0.01, osl=osl)
    common.set_linear_exr_output(scene, (w, h))
    common.set_world_background(scene, float(environment))
    common.add_orthographic_camera(scene, view_dir, ortho_scale, up_hint=up_hint)
    mesh = uv_sphere_mesh(name + "_sphere", segments)
    if material is not None:
        material.cycles.emission_sampling = 'NONE'
        mesh.materials.append(material)
    obj = bpy.data.objects.new(name + "_sphere", mesh)
    scene.collection.objects.link(obj)

    px = ortho_scale / w
    xs = (np.arange(w) + 0.5 - w / 2.0) * px
    ys = (h / 2.0 - np.arange(h) - 0.5) * px
    X, Y = np.meshgrid(xs, ys)
    r2 = X ** 2 + Y ** 2
    mask = np.sqrt(r2) <= 1.0 - erode * px - (1.0 - np.cos(np.pi / segments))
    Z = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    n_cam = np.stack([X, Y, Z], axis=-1)
    normal = np.where(mask[..., None], n_cam @ basis.T, 0.0)
    normal = np.where(mask[..., None], normalize(np.where(mask[..., None], normal, 1.0)), 0.0)
    wo = np.where(mask[..., None], view_dir, 0.0)
    cos_o = np.einsum("ijk,ijk->ij", normal, wo)
    return FurnaceScene(scene=scene, sphere=obj, material=material, view_dir=view_dir,
                        environment=float(environment), resolution=(w, h), mask=mask,
                        normal=normal, cos_o=cos_o, wo=wo)


def render(furnace, path=None):
    """Render the furnace to a float32 EXR (default: a temporary file, removed
    after reading); return RGB ``(H, W, 3)``, row 0 = top.  The wall time is
    stored in ``furnace.last_render_seconds``."""
    if path is None:
        img, furnace.last_render_seconds = common.render_image(furnace.scene, "furnace_")
        return img
    furnace.last_render_seconds = common.render_to_exr(furnace.scene, path)
    return common.read_exr(path, 3)
