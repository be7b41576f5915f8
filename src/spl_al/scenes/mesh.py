"""Triangle meshes of analytic shapes: lofts, surfaces of revolution, tubes, boxes.

Every shape of the procedural scenes is a tessellated analytic surface. One exact
ray-triangle intersection (``spl_al.scenes.raycast``) then serves every shape,
where closed-form ray intersections exist only for quadrics. With ``n_sides``
segments around a circle the radial tessellation error is r (1 - cos(pi / n_sides)),
0.9% of the radius at 24 sides: far below the depth resolution of the sensors.

Coordinates: X right, Y forward (away from the sensor), Z up, metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Mesh:
    """Triangle mesh with per-face material and part label.

    Attributes:
        vertices: (V, 3) float64 positions, metres.
        faces: (F, 3) int64 vertex indices.
        albedo: (F,) float64 Lambertian albedo in [0, 1] of each face.
        label: (F,) int64 part label of each face (a class index of the scene).
        smooth: (F,) bool, True where the face interpolates vertex normals (curved
            surfaces), False where it is shaded flat (boxes, prisms).
    """

    vertices: np.ndarray
    faces: np.ndarray
    albedo: np.ndarray
    label: np.ndarray
    smooth: np.ndarray

    def transformed(self, rotation: np.ndarray, translation) -> Mesh:
        """The mesh with vertices mapped to ``rotation @ v + translation``."""
        v = self.vertices @ np.asarray(rotation, dtype=np.float64).T + np.asarray(translation)
        return Mesh(v, self.faces, self.albedo, self.label, self.smooth)

    def scaled(self, factor) -> Mesh:
        """The mesh scaled about the origin by a scalar or per-axis (3,) factor."""
        return Mesh(
            self.vertices * np.asarray(factor), self.faces, self.albedo, self.label, self.smooth
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(min corner, max corner) of the vertices, each (3,)."""
        return self.vertices.min(axis=0), self.vertices.max(axis=0)


def loft(
    rings,
    albedo: float,
    label: int = 0,
    *,
    cap_start=True,
    cap_end=True,
    closed=False,
    smooth=True,
) -> Mesh:
    """Surface through a sequence of closed polygons (rings).

    Args:
        rings: (S, P, 3) ring s, point i; consecutive rings are joined by quads.
        cap_start, cap_end: close the first / last ring with a fan around its centroid.
        closed: join the last ring back to the first (a torus); no caps then.
    """
    rings = np.asarray(rings, dtype=np.float64)
    n_rings, n_pts = rings.shape[:2]
    idx = np.arange(n_rings * n_pts).reshape(n_rings, n_pts)
    nxt = np.roll(idx, -1, axis=1)
    ring_pairs = n_rings if closed else n_rings - 1
    a, b = idx[:ring_pairs], nxt[:ring_pairs]
    c, d = np.roll(idx, -1, axis=0)[:ring_pairs], np.roll(nxt, -1, axis=0)[:ring_pairs]
    faces = [np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)]
    vertices = [rings.reshape(-1, 3)]
    n_side = len(faces[0]) + len(faces[1])
    n_v = n_rings * n_pts
    for use, s, flip in ((cap_start and not closed, 0, True), (cap_end and not closed, -1, False)):
        if not use:
            continue
        # Caps get their own rim vertices so that their flat normals stay flat.
        vertices += [rings[s], rings[s].mean(axis=0, keepdims=True)]
        ring = n_v + np.arange(n_pts)
        fan = np.stack([np.full(n_pts, n_v + n_pts), np.roll(ring, -1), ring], -1)
        faces.append(fan[:, ::-1] if flip else fan)
        n_v += n_pts + 1
    faces = np.concatenate(faces).astype(np.int64)
    is_smooth = np.zeros(len(faces), dtype=bool)
    is_smooth[:n_side] = smooth
    return Mesh(
        np.concatenate(vertices),
        faces,
        np.full(len(faces), float(albedo)),
        np.full(len(faces), int(label), dtype=np.int64),
        is_smooth,
    )


def _circle(n_sides: int, phase: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    ang = phase + 2 * np.pi * np.arange(n_sides) / n_sides
    return np.cos(ang), np.sin(ang)


def lathe(
    radius, height, albedo: float, *, label: int = 0, n_sides: int = 20, scale_xy=(1.0, 1.0), **kw
) -> Mesh:
    """Surface of revolution about Z: ring k has radius ``radius[k]`` at ``height[k]``.

    A radius of 0 closes the surface at that end; other ends get flat caps.
    ``scale_xy`` stretches the rings into ellipses (an ellipsoid from a sphere profile).
    """
    r = np.asarray(radius, dtype=np.float64)
    z = np.asarray(height, dtype=np.float64)
    cx, cy = _circle(n_sides)
    rings = np.stack(
        [
            r[:, None] * cx * scale_xy[0],
            r[:, None] * cy * scale_xy[1],
            np.broadcast_to(z[:, None], (z.size, n_sides)),
        ],
        axis=-1,
    )
    kw.setdefault("cap_start", bool(r[0] > 0))
    kw.setdefault("cap_end", bool(r[-1] > 0))
    return loft(rings, albedo, label, **kw)


def ellipsoid(
    radii, albedo: float, *, label: int = 0, n_sides: int = 16, n_rings: int = 10
) -> Mesh:
    """Ellipsoid centred at the origin with semi-axes ``radii`` = (rx, ry, rz)."""
    theta = np.linspace(0.0, np.pi, n_rings + 1)
    return lathe(
        np.sin(theta),
        -np.cos(theta) * radii[2],
        albedo,
        label=label,
        n_sides=n_sides,
        scale_xy=(radii[0], radii[1]),
    )


def _frames(path: np.ndarray, up=None) -> tuple[np.ndarray, np.ndarray]:
    """Two unit normals (K, 3) each, perpendicular to the path's tangents.

    ``up`` is a reference direction that must never be parallel to the path (for a
    planar curve: the plane's normal); by default the axis least aligned with it.
    """
    tangent = np.gradient(path, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    if up is None:
        up = np.eye(3)[np.argmin(np.abs(tangent).sum(axis=0))]
    up = np.asarray(up, dtype=np.float64)
    n1 = up - (tangent @ up)[:, None] * tangent
    n1 /= np.linalg.norm(n1, axis=1, keepdims=True)
    n2 = np.cross(tangent, n1)
    return n1, n2


def tube(
    path,
    radius,
    albedo: float,
    *,
    label: int = 0,
    n_sides: int = 8,
    up=None,
    closed=False,
    ellipse=1.0,
) -> Mesh:
    """Tube of (K,) radii swept along a (K, 3) polyline; capped unless ``closed``.

    ``ellipse`` scales the cross-section along the second normal (flattened tubes).
    """
    path = np.asarray(path, dtype=np.float64)
    r = np.broadcast_to(np.asarray(radius, dtype=np.float64), (path.shape[0],))
    if closed:
        # Periodic tangents: pad with the wrapped neighbours.
        padded = np.concatenate([path[-1:], path, path[:1]])
        n1, n2 = _frames(padded, up)
        n1, n2 = n1[1:-1], n2[1:-1]
    else:
        n1, n2 = _frames(path, up)
    cx, cy = _circle(n_sides)
    rings = path[:, None, :] + r[:, None, None] * (
        cx[None, :, None] * n1[:, None, :] + ellipse * cy[None, :, None] * n2[:, None, :]
    )
    return loft(rings, albedo, label, cap_start=not closed, cap_end=not closed, closed=closed)


def cylinder_between(
    p0, p1, radius, albedo: float, *, label: int = 0, n_sides: int = 8, radius_end=None
) -> Mesh:
    """Capped (truncated-cone) tube from point p0 to p1."""
    r1 = radius if radius_end is None else radius_end
    return tube(
        np.stack([np.asarray(p0, float), np.asarray(p1, float)]),
        [radius, r1],
        albedo,
        label=label,
        n_sides=n_sides,
    )


def torus(
    major_radius: float,
    minor_radius: float,
    albedo: float,
    *,
    label: int = 0,
    n_major: int = 32,
    n_minor: int = 6,
) -> Mesh:
    """Torus in the XZ plane (a wheel seen side-on from -Y), centred at the origin."""
    ang = 2 * np.pi * np.arange(n_major) / n_major
    path = np.stack(
        [major_radius * np.cos(ang), np.zeros(n_major), major_radius * np.sin(ang)], axis=1
    )
    return tube(
        path, minor_radius, albedo, label=label, n_sides=n_minor, up=(0.0, 1.0, 0.0), closed=True
    )


def box(size, albedo: float, label: int = 0, center=(0.0, 0.0, 0.0)) -> Mesh:
    """Axis-aligned box of full ``size`` = (sx, sy, sz) around ``center``; flat shaded."""
    sx, sy, sz = (float(s) / 2 for s in size)
    ring = np.array([[-sx, -sy], [sx, -sy], [sx, sy], [-sx, sy]])
    rings = np.stack(
        [np.column_stack([ring, np.full(4, -sz)]), np.column_stack([ring, np.full(4, sz)])]
    ) + np.asarray(center, dtype=np.float64)
    return loft(rings, albedo, label, smooth=False)


def prism(
    polygon_xz, depth: float, albedo: float, *, label: int = 0, center=(0.0, 0.0, 0.0)
) -> Mesh:
    """Convex polygon in the XZ plane (P, 2) extruded along Y by ``depth``; flat shaded."""
    poly = np.asarray(polygon_xz, dtype=np.float64)
    y = depth / 2
    rings = np.stack(
        [
            np.column_stack([poly[:, 0], np.full(len(poly), -y), poly[:, 1]]),
            np.column_stack([poly[:, 0], np.full(len(poly), y), poly[:, 1]]),
        ]
    ) + np.asarray(center, dtype=np.float64)
    return loft(rings, albedo, label, smooth=False)


def merge(meshes: list[Mesh]) -> Mesh:
    """One mesh holding every face of ``meshes``."""
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(
        np.concatenate([m.vertices for m in meshes]),
        np.concatenate([m.faces + o for m, o in zip(meshes, offsets, strict=True)]),
        np.concatenate([m.albedo for m in meshes]),
        np.concatenate([m.label for m in meshes]),
        np.concatenate([m.smooth for m in meshes]),
    )


def corner_normals(mesh: Mesh) -> np.ndarray:
    """(F, 3, 3) unit normal at each corner of each face: area-weighted vertex
    normals on smooth faces, the face normal on flat ones."""
    tri = mesh.vertices[mesh.faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n_vertices = len(mesh.vertices)
    corners = mesh.faces.ravel()
    weights = np.repeat(face_n, 3, axis=0)
    vn = np.stack([np.bincount(corners, weights[:, k], n_vertices) for k in range(3)], axis=1)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
    unit = face_n / np.maximum(np.linalg.norm(face_n, axis=1, keepdims=True), 1e-300)
    return np.where(mesh.smooth[:, None, None], vn[mesh.faces], unit[:, None, :])


def rotation_z(angle_rad: float) -> np.ndarray:
    """Rotation about Z (yaw), counter-clockwise seen from above."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_x(angle_rad: float) -> np.ndarray:
    """Rotation about X (pitch of a Y-forward frame: positive lifts +Y towards +Z)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_y(angle_rad: float) -> np.ndarray:
    """Rotation about Y (roll of a Y-forward frame)."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
