"""Ray casting for a scanning single-photon LiDAR: one ray per pixel of a uniform
angular grid, exact ray-triangle intersections (Moeller-Trumbore), analytic planes.

A scanning SPL steers one beam over a grid of equally spaced azimuth and elevation
angles, so pixel (r, c) looks along

    d(r, c) = (cos el_r sin az_c, cos el_r cos az_c, sin el_r)

in the sensor frame (X right, Y forward, Z up); the depth it measures is the range
t along that ray (time of flight, not the Z-buffer depth of a camera).

Candidate (ray, triangle) pairs come from each triangle's bounding sphere: the
cone of directions it subtends bounds the pixel rows and columns it can cover, so
the cost grows with the pixels each triangle covers, not pixels x triangles.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from spl_al.scenes.mesh import Mesh, corner_normals


@dataclass(frozen=True)
class ScanGrid:
    """Uniform angular pixel grid of a scanning sensor.

    Attributes:
        shape: (rows, cols) of the image.
        elevation_deg: (top, bottom) elevation of the first and last row centre, degrees.
        azimuth_deg: (left, right) azimuth of the first and last column centre, degrees;
            the span must stay below 180 degrees.
    """

    shape: tuple[int, int]
    elevation_deg: tuple[float, float]
    azimuth_deg: tuple[float, float]

    def __post_init__(self) -> None:
        rows, cols = self.shape
        if int(rows) < 1 or int(cols) < 1:
            raise ValueError(f"shape must be (rows, cols) >= 1, got {self.shape!r}.")
        if (
            not self.elevation_deg[0] > self.elevation_deg[1]
            or max(map(abs, self.elevation_deg)) >= 90
        ):
            raise ValueError(
                "elevation_deg must be (top, bottom) with 90 > top > bottom > -90, "
                f"got {self.elevation_deg!r}."
            )
        if (
            not self.azimuth_deg[1] > self.azimuth_deg[0]
            or self.azimuth_deg[1] - self.azimuth_deg[0] >= 180
        ):
            raise ValueError(
                "azimuth_deg must be (left, right) with left < right and a span below 180, "
                f"got {self.azimuth_deg!r}."
            )

    @classmethod
    def square_pixels(
        cls, shape, vertical_fov_deg: float, elevation_centre_deg: float = 0.0
    ) -> ScanGrid:
        """Grid whose rows span ``vertical_fov_deg`` (edge to edge) with square angular
        pixels, centred on azimuth 0 and elevation ``elevation_centre_deg``."""
        rows, cols = (int(shape[0]), int(shape[1]))
        step = vertical_fov_deg / rows
        half_r, half_c = (rows - 1) * step / 2, (cols - 1) * step / 2
        return cls(
            (rows, cols),
            (elevation_centre_deg + half_r, elevation_centre_deg - half_r),
            (-half_c, half_c),
        )

    @property
    def elevation_rad(self) -> np.ndarray:
        """(rows,) elevation of each row centre, radians, top row first."""
        return np.deg2rad(np.linspace(*self.elevation_deg, self.shape[0]))

    @property
    def azimuth_rad(self) -> np.ndarray:
        """(cols,) azimuth of each column centre, radians, left column first."""
        return np.deg2rad(np.linspace(*self.azimuth_deg, self.shape[1]))

    def directions(self) -> np.ndarray:
        """(rows, cols, 3) unit ray directions in the sensor frame (read-only, cached)."""
        return _directions(self)

    def _compute_directions(self) -> np.ndarray:
        el = self.elevation_rad[:, None]
        az = self.azimuth_rad[None, :]
        return np.stack(
            np.broadcast_arrays(np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el)),
            axis=-1,
        )

    def _index_range(self, lo_rad, hi_rad, first_deg, last_deg, n):
        """Pixel indices [i0, i1] whose centres lie in [lo, hi] (angles along an axis
        running from ``first_deg`` at index 0 to ``last_deg`` at index n - 1)."""
        if n == 1:
            centre = np.deg2rad(first_deg)
            inside = (lo_rad <= centre) & (centre <= hi_rad)
            return np.zeros_like(lo_rad, dtype=np.int64), np.where(inside, 0, -1).astype(np.int64)
        first, step = np.deg2rad(first_deg), np.deg2rad((last_deg - first_deg) / (n - 1))
        a = (lo_rad - first) / step
        b = (hi_rad - first) / step
        i0 = np.ceil(np.minimum(a, b) - 1e-9)
        i1 = np.floor(np.maximum(a, b) + 1e-9)
        return np.clip(i0, 0, n).astype(np.int64), np.clip(i1, -1, n - 1).astype(np.int64)


@functools.lru_cache(maxsize=16)
def _directions(grid: ScanGrid) -> np.ndarray:
    d = grid._compute_directions()
    d.setflags(write=False)
    return d


@dataclass(frozen=True)
class Pose:
    """Sensor pose: ``position`` (3,) in the world and ``rotation`` (3, 3) mapping
    sensor-frame vectors to world-frame vectors."""

    position: np.ndarray
    rotation: np.ndarray

    @classmethod
    def looking_at(cls, position, target) -> Pose:
        """Pose at ``position`` whose forward axis points at ``target``, no roll."""
        position = np.asarray(position, dtype=np.float64)
        fwd = np.asarray(target, dtype=np.float64) - position
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        if np.linalg.norm(right) < 1e-9:
            raise ValueError("the sensor cannot look straight up or down with this pose model.")
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        return cls(position, np.column_stack([right, fwd, up]))

    def to_sensor(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 3) in the sensor frame."""
        return (np.asarray(points) - self.position) @ self.rotation


@dataclass
class Hits:
    """Nearest surface along every ray of a grid; each field is (rows, cols).

    range_m: range along the ray, metres; inf where nothing is hit.
    label: label of the surface hit (-1 where nothing is hit).
    albedo: Lambertian albedo of the surface hit (0 where nothing is hit).
    cos_incidence: |cos| of the angle between the ray and the surface normal.
    """

    range_m: np.ndarray
    label: np.ndarray
    albedo: np.ndarray
    cos_incidence: np.ndarray

    @classmethod
    def empty(cls, shape) -> Hits:
        """Hits of ``shape`` where no ray hits anything (infinite range, label -1)."""
        return cls(
            np.full(shape, np.inf), np.full(shape, -1, np.int64), np.zeros(shape), np.zeros(shape)
        )

    def nearest(self, other: Hits) -> Hits:
        """Per pixel, whichever of ``self`` and ``other`` is hit first."""
        take = other.range_m < self.range_m
        return Hits(
            *(np.where(take, b, a) for a, b in zip(self.fields(), other.fields(), strict=True))
        )

    def fields(self):
        """(range_m, label, albedo, cos_incidence), each (rows, cols)."""
        return (self.range_m, self.label, self.albedo, self.cos_incidence)


def _pixel_boxes(grid: ScanGrid, tri: np.ndarray):
    """Rows [r0, r1] and columns [c0, c1] each triangle (F, 3, 3, sensor frame) can cover.

    For triangles wholly in front of the sensor (y > 0) the box is exact: in the
    gnomonic coordinates u = x / y, w = z / y straight edges stay straight, so the
    (u, w) box of the vertices bounds the triangle, and az = atan(u),
    el = atan(w / sqrt(1 + u^2)) are monotone on it. Other triangles fall back to
    the cone their bounding sphere subtends (or the whole image when the sensor
    is inside that sphere).
    """
    rows, cols = grid.shape
    y = tri[..., 1]
    front = (y > 1e-9).all(axis=1)
    safe_y = np.where(front[:, None], y, 1.0)
    u = tri[..., 0] / safe_y
    w = tri[..., 2] / safe_y
    u0, u1, w0, w1 = u.min(1), u.max(1), w.min(1), w.max(1)
    u_small = np.where((u0 <= 0) & (u1 >= 0), 0.0, np.minimum(np.abs(u0), np.abs(u1)))
    u_large = np.maximum(np.abs(u0), np.abs(u1))
    el_hi = np.arctan(w1 / np.sqrt(1 + np.where(w1 > 0, u_small, u_large) ** 2))
    el_lo = np.arctan(w0 / np.sqrt(1 + np.where(w0 < 0, u_small, u_large) ** 2))
    az_lo, az_hi = np.arctan(u0), np.arctan(u1)

    if not front.all():
        centre = tri.mean(axis=1)
        radius = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1) * (1 + 1e-9) + 1e-12
        dist = np.linalg.norm(centre, axis=1)
        half = np.arcsin(np.clip(radius / np.maximum(dist, 1e-300), 0.0, 1.0))
        el_c = np.arcsin(np.clip(centre[:, 2] / np.maximum(dist, 1e-300), -1.0, 1.0))
        az_c = np.arctan2(centre[:, 0], centre[:, 1])
        top = np.minimum(np.abs(el_c) + half, 1.5)
        daz = np.where(
            np.abs(el_c) + half < np.pi / 2,
            np.arcsin(np.clip(np.sin(half) / np.cos(top), 0, 1)),
            np.pi,
        )
        # A cone wider than a quarter turn, or around the sensor, may cover anything.
        whole = (dist <= radius) | (daz >= np.pi / 2)
        back = ~front
        el_lo = np.where(back, np.where(whole, -np.pi, el_c - half), el_lo)
        el_hi = np.where(back, np.where(whole, np.pi, el_c + half), el_hi)
        az_lo = np.where(back, np.where(whole, -np.pi, az_c - daz), az_lo)
        az_hi = np.where(back, np.where(whole, np.pi, az_c + daz), az_hi)
    r0, r1 = grid._index_range(el_lo, el_hi, *grid.elevation_deg, rows)
    c0, c1 = grid._index_range(az_lo, az_hi, *grid.azimuth_deg, cols)
    return r0, r1, c0, c1


def cast_mesh(grid: ScanGrid, pose: Pose, mesh: Mesh, min_range_m: float = 1e-6) -> Hits:
    """Nearest intersection of every pixel's ray with ``mesh`` (Moeller-Trumbore).

    With the ray origin at the sensor (o = 0) and face vertices v0, v1, v2,
    e1 = v1 - v0, e2 = v2 - v0, s = -v0 and q = s x e1, the ray x = t d meets the
    face at barycentric (u, v) and range t with

        det = d . (e2 x e1),  u = d . (e2 x s) / det,  v = d . q / det,  t = e2 . q / det,

    a hit when u, v >= 0, u + v <= 1 and t > min_range_m. Everything but the three
    dot products with d is per face, so each (ray, face) pair costs 9 products.

    Returns Hits with the range along the ray, the face's label and albedo, and the
    cosine of incidence from the corner normals interpolated at the hit.
    """
    cols = grid.shape[1]
    hits = Hits.empty(grid.shape)
    if len(mesh.faces) == 0:
        return hits
    tri = pose.to_sensor(mesh.vertices)[mesh.faces]  # (F, 3, 3) in the sensor frame
    r0, r1, c0, c1 = _pixel_boxes(grid, tri)
    n_r = np.maximum(r1 - r0 + 1, 0)
    n_c = np.maximum(c1 - c0 + 1, 0)
    count = n_r * n_c
    face = np.repeat(np.arange(len(tri)), count)
    if face.size == 0:
        return hits
    local = np.arange(face.size) - np.repeat(np.cumsum(count) - count, count)
    ray = (r0[face] + local // n_c[face]) * cols + c0[face] + local % n_c[face]

    v0 = tri[:, 0]
    e1 = tri[:, 1] - v0
    e2 = tri[:, 2] - v0
    q = np.cross(-v0, e1)
    per_face = np.concatenate([np.cross(e2, e1), np.cross(e2, -v0), q], axis=1)  # (F, 9)
    t_num = np.einsum("ij,ij->i", e2, q)
    dirs = grid.directions().reshape(-1, 3)
    d = dirs[ray]
    f = per_face[face]
    det = d[:, 0] * f[:, 0] + d[:, 1] * f[:, 1] + d[:, 2] * f[:, 2]
    u_num = d[:, 0] * f[:, 3] + d[:, 1] * f[:, 4] + d[:, 2] * f[:, 5]
    v_num = d[:, 0] * f[:, 6] + d[:, 1] * f[:, 7] + d[:, 2] * f[:, 8]
    ok = np.abs(det) > 1e-18
    inv = 1.0 / np.where(ok, det, 1.0)
    u = u_num * inv
    v = v_num * inv
    t = t_num[face] * inv
    ok &= (u >= 0) & (v >= 0) & (u + v <= 1) & (t > min_range_m)
    if not ok.any():
        return hits
    ray, face, u, v, t = ray[ok], face[ok], u[ok], v[ok], t[ok]
    order = np.lexsort((t, ray))
    first = order[np.r_[True, ray[order][1:] != ray[order][:-1]]]
    ray, face, u, v, t = ray[first], face[first], u[first], v[first], t[first]

    d = dirs[ray]
    normals = corner_normals(mesh)[face] @ pose.rotation  # world -> sensor frame
    n = (
        (1 - u - v)[:, None] * normals[:, 0]
        + u[:, None] * normals[:, 1]
        + v[:, None] * normals[:, 2]
    )
    cos = np.abs(np.einsum("ij,ij->i", n, d)) / np.maximum(np.linalg.norm(n, axis=1), 1e-300)
    for field, value in zip(
        hits.fields(), (t, mesh.label[face], mesh.albedo[face], cos), strict=True
    ):
        field.reshape(-1)[ray] = value
    return hits


def cast_plane(
    grid: ScanGrid, pose: Pose, point, normal, *, albedo, label: int, min_range_m: float = 1e-6
):
    """Intersection of every ray with the infinite plane through ``point`` with ``normal``.

    Args:
        albedo: a float, or a function of the (n, 3) world hit points returning (n,) albedo.

    Returns:
        (Hits, world hit points (rows, cols, 3), NaN where the plane is not hit).
    """
    d_world = grid.directions() @ pose.rotation.T
    normal = np.asarray(normal, dtype=np.float64)
    normal = normal / np.linalg.norm(normal)
    denom = d_world @ normal
    gap = (np.asarray(point, dtype=np.float64) - pose.position) @ normal
    with np.errstate(divide="ignore", invalid="ignore"):
        t = gap / denom
    hit = np.isfinite(t) & (t > min_range_m)
    hits = Hits.empty(grid.shape)
    points = np.full((*grid.shape, 3), np.nan)
    points[hit] = pose.position + t[hit, None] * d_world[hit]
    hits.range_m[hit] = t[hit]
    hits.label[hit] = label
    hits.albedo[hit] = albedo(points[hit]) if callable(albedo) else albedo
    hits.cos_incidence[hit] = np.abs(denom[hit])
    return hits, points
