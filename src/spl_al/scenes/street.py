"""Procedural street scenes for SPL semantic segmentation, in the spirit of
Virtual KITTI: a LiDAR-like range image (e.g. 64 rows) with per-pixel labels.

A (possibly curving) road with lane markings, raised sidewalks and terrain on
both sides, rows of buildings, parked and driving cars, pedestrians, poles
(street lamps, sign posts) and trees. Layout, counts and positions are drawn per
scene. Pixels whose ray meets nothing within ``max_range_m`` (sky, far away) get
``IGNORE_INDEX`` and are invalid.

World frame: X right, Y forward along the road, Z up; metres. The sensor sits at
(0, 0, height) and looks along +Y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spl_al.label_codes import IGNORE_INDEX
from spl_al.scenes import mesh as M
from spl_al.scenes.objects import human
from spl_al.scenes.raycast import Hits, Pose, ScanGrid, cast_mesh

STREET_CLASSES = ("road", "sidewalk", "building", "car", "pedestrian", "pole", "vegetation")
"""Segmentation classes; "sidewalk" covers sidewalks, curbs and terrain beside the road."""

ROAD, SIDEWALK, BUILDING, CAR, PEDESTRIAN, POLE, VEGETATION = range(len(STREET_CLASSES))
CURB_HEIGHT_M = 0.15


@dataclass(frozen=True)
class Road:
    """Road centreline x_c(y) = offset_m + curvature * y^2 / 2 and half-width."""

    offset_m: float
    curvature_per_m: float
    half_width_m: float
    sidewalk_m: float

    def centre_x(self, y):
        """Road centre x (m) at distances ``y`` (m) along the street."""
        return self.offset_m + 0.5 * self.curvature_per_m * np.asarray(y) ** 2

    def heading(self, y):
        """Yaw about Z that turns +Y into the road's direction at ``y``."""
        return -np.arctan(self.curvature_per_m * np.asarray(y))

    def lateral(self, x, y):
        """Signed lateral distance from the centreline (approximately, for small curvature)."""
        return (np.asarray(x) - self.centre_x(y)) * np.cos(self.heading(y))

    def place(self, lateral_m: float, y: float) -> tuple[np.ndarray, float]:
        """World point at ``lateral_m`` from the centreline at ``y``, and the road's yaw there."""
        yaw = float(self.heading(y))
        x = float(self.centre_x(y)) + lateral_m / np.cos(yaw)
        return np.array([x, y, 0.0]), yaw


@dataclass
class StreetImage:
    """One street scene; each image is (rows, cols).

    depth_m: float32 range along each ray, NaN where nothing returns.
    reflectance: float32 albedo * |cos incidence| (no range falloff: a LiDAR's
        intensity channel is range-compensated), 0 where nothing returns.
    valid: bool, True where a surface returns within ``max_range_m``.
    labels: uint8 class index into ``STREET_CLASSES``, ``IGNORE_INDEX`` where invalid.
    """

    depth_m: np.ndarray
    reflectance: np.ndarray
    valid: np.ndarray
    labels: np.ndarray


def default_grid(image_shape=(64, 256)) -> ScanGrid:
    """A 64-beam-like grid: elevation +8 to -22 degrees, azimuth -45 to +45 degrees."""
    return ScanGrid(tuple(int(s) for s in image_shape), (8.0, -22.0), (-45.0, 45.0))


def _ground(grid: ScanGrid, pose: Pose, road: Road, rng: np.random.Generator) -> Hits:
    """Road at z = 0 within the half-width, sidewalk and terrain raised by the curb height
    outside it, and the curb faces between them (found by bisection along the ray)."""
    d = grid.directions() @ pose.rotation.T
    o = pose.position
    hits = Hits.empty(grid.shape)
    down = d[..., 2] < -1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        t_top = np.where(down, (CURB_HEIGHT_M - o[2]) / d[..., 2], np.inf)
        t_low = np.where(down, -o[2] / d[..., 2], np.inf)
    # Rays that never come down get a far finite point: they are masked out below.
    p_top = o + np.where(down, t_top, 1e6)[..., None] * d
    p_low = o + np.where(down, t_low, 1e6)[..., None] * d
    lat_top = np.abs(road.lateral(p_top[..., 0], p_top[..., 1]))
    lat_low = np.abs(road.lateral(p_low[..., 0], p_low[..., 1]))
    on_side = down & (lat_top >= road.half_width_m)
    on_road = down & ~on_side & (lat_low < road.half_width_m)
    on_curb = down & ~on_side & ~on_road
    t_curb = _bisect_curb(o, d, t_top=t_top, t_low=t_low, road=road, mask=on_curb)

    hits.range_m = np.where(
        on_side, t_top, np.where(on_road, t_low, np.where(on_curb, t_curb, np.inf))
    )
    hits.label = np.where(on_road, ROAD, np.where(on_side | on_curb, SIDEWALK, -1))
    asphalt, pavement, grass = (
        rng.uniform(0.08, 0.2),
        rng.uniform(0.25, 0.45),
        rng.uniform(0.3, 0.55),
    )
    paint = rng.uniform(0.6, 0.85)
    lat_signed = road.lateral(p_low[..., 0], p_low[..., 1])
    dash = (np.mod(p_low[..., 1], 9.0) < 3.0) & (np.abs(lat_signed) < 0.08)
    edge = np.abs(np.abs(lat_signed) - (road.half_width_m - 0.3)) < 0.08
    road_albedo = np.where(dash | edge, paint, asphalt)
    side_albedo = np.where(lat_top < road.half_width_m + road.sidewalk_m, pavement, grass)
    hits.albedo = np.where(
        on_road, road_albedo, np.where(on_side, side_albedo, np.where(on_curb, pavement, 0.0))
    )
    hits.cos_incidence = np.where(on_curb, np.abs(d[..., 0]), np.abs(d[..., 2]))
    return hits


def _bisect_curb(o, d, *, t_top, t_low, road: Road, mask, steps: int = 20) -> np.ndarray:
    """Range where a ray crosses |lateral| = half-width between the two ground levels."""
    out = np.full(mask.shape, np.inf)
    if not mask.any():
        return out
    lo, hi = t_top[mask], t_low[mask]
    dm = d[mask]
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        p = o + mid[:, None] * dm
        outside = np.abs(road.lateral(p[:, 0], p[:, 1])) >= road.half_width_m
        hi = np.where(outside, mid, hi)
        lo = np.where(outside, lo, mid)
    out[mask] = hi
    return out


def car(rng: np.random.Generator) -> M.Mesh:
    """Car or van along +X: rounded body, glass cabin, four wheels."""
    van = rng.random() < 0.2
    length = rng.uniform(4.5, 5.5) if van else rng.uniform(3.8, 4.9)
    width = rng.uniform(1.7, 1.95)
    body_h = rng.uniform(0.6, 0.8)
    paint = rng.uniform(0.08, 0.8)
    glass = rng.uniform(0.03, 0.1)
    wheel_r = rng.uniform(0.3, 0.36)
    clearance = 0.18
    xs = np.linspace(-length / 2, length / 2, 6)
    rings = []
    for k, x in enumerate(xs):
        nose = 0.85 if k in (0, 5) else 1.0
        z0, z1 = clearance, clearance + body_h * nose
        rings.append(
            [[x, -width / 2, z0], [x, width / 2, z0], [x, width / 2, z1], [x, -width / 2, z1]]
        )
    parts = [M.loft(np.array(rings), paint, smooth=False)]
    top = clearance + body_h
    if van:
        cab = [(-length / 2, 0), (length / 2 - 0.5, 0), (length / 2 - 1.0, 1.1), (-length / 2, 1.1)]
    else:
        roof = rng.uniform(0.45, 0.6)
        rear = -length / 2 + rng.uniform(0.4, 0.9)
        front = length / 2 - rng.uniform(1.0, 1.4)
        cab = [(rear, 0), (front, 0), (front - 0.7, roof), (rear + 0.5, roof)]
    parts.append(M.prism(cab, width * 0.88, glass, center=(0, 0, top)))
    for x in (-length / 2 + 0.8, length / 2 - 0.8):
        for y in (-width / 2 + 0.15, width / 2 - 0.15):
            parts.append(
                M.cylinder_between(
                    (x, y - 0.12, wheel_r), (x, y + 0.12, wheel_r), wheel_r, 0.05, n_sides=10
                )
            )
    mesh = M.merge(parts)
    mesh.label[:] = CAR
    return mesh


def tree(rng: np.random.Generator) -> M.Mesh:
    """Trunk and a lumpy crown (an ellipsoid with random radial bumps)."""
    trunk_h = rng.uniform(1.5, 4.0)
    crown_r = rng.uniform(1.2, 3.5)
    trunk = M.cylinder_between(
        (0, 0, 0),
        (0, 0, trunk_h + crown_r * 0.5),
        rng.uniform(0.1, 0.3),
        rng.uniform(0.15, 0.35),
        n_sides=8,
    )
    crown = M.ellipsoid(
        (crown_r, crown_r, crown_r * rng.uniform(0.8, 1.4)),
        rng.uniform(0.3, 0.6),
        n_sides=14,
        n_rings=9,
    )
    v = crown.vertices
    lump = 1 + 0.15 * np.sin(3 * v[:, 0] / crown_r + rng.uniform(0, 6)) * np.sin(
        3 * v[:, 1] / crown_r + rng.uniform(0, 6)
    )
    crown = M.Mesh(v * lump[:, None], crown.faces, crown.albedo, crown.label, crown.smooth)
    crown = crown.transformed(np.eye(3), (0, 0, trunk_h + crown_r))
    mesh = M.merge([trunk, crown])
    mesh.label[:] = VEGETATION
    return mesh


def bush(rng: np.random.Generator, length: float) -> M.Mesh:
    """A bush of ``length`` metres along the street: a squashed ellipsoid on the ground."""
    mesh = M.ellipsoid(
        (length / 2, rng.uniform(0.4, 0.9), rng.uniform(0.4, 1.0)),
        rng.uniform(0.3, 0.55),
        n_sides=12,
        n_rings=6,
    )
    mesh = mesh.transformed(np.eye(3), (0, 0, 0.3))
    mesh.label[:] = VEGETATION
    return mesh


def pole(rng: np.random.Generator) -> M.Mesh:
    """Street lamp (tall pole, arm, lamp head) or sign post (short pole, plate)."""
    metal = rng.uniform(0.2, 0.5)
    if rng.random() < 0.6:
        h = rng.uniform(5.0, 9.0)
        arm = rng.uniform(1.0, 2.5)
        parts = [
            M.cylinder_between(
                (0, 0, 0), (0, 0, h), rng.uniform(0.08, 0.14), metal, radius_end=0.06
            ),
            M.cylinder_between((0, 0, h - 0.1), (-arm, 0, h + 0.2), 0.05, metal),
            M.box((0.6, 0.3, 0.15), 0.6, center=(-arm, 0, h + 0.1)),
        ]
    else:
        h = rng.uniform(2.2, 3.2)
        parts = [
            M.cylinder_between((0, 0, 0), (0, 0, h), 0.04, metal),
            M.box(
                (0.05, rng.uniform(0.5, 0.8), rng.uniform(0.5, 0.8)),
                rng.uniform(0.7, 0.95),
                center=(0, 0, h - 0.3),
            ),
        ]
    mesh = M.merge(parts)
    mesh.label[:] = POLE
    return mesh


def building_block(rng: np.random.Generator, frontage: float) -> M.Mesh:
    """Building along +X with its facade at y = 0, extending to +Y (away from the road)."""
    depth = rng.uniform(8.0, 16.0)
    height = rng.uniform(4.0, 25.0)
    wall = rng.uniform(0.25, 0.7)
    parts = [M.box((frontage, depth, height), wall, center=(0, depth / 2, height / 2))]
    if height < 10 and rng.random() < 0.5:
        roof = rng.uniform(2.0, 4.0)
        parts.append(
            M.prism(
                [(-frontage / 2, 0), (frontage / 2, 0), (0, roof)],
                depth,
                wall * 0.6,
                center=(0, depth / 2, height),
            )
        )
    mesh = M.merge(parts)
    mesh.label[:] = BUILDING
    return mesh


def _on_road(
    mesh: M.Mesh, road: Road, lateral_m: float, y: float, extra_yaw: float = 0.0, z: float = 0.0
) -> M.Mesh:
    point, yaw = road.place(lateral_m, y)
    # Object frames run along +X; the road runs along +Y.
    lift = np.array([0.0, 0.0, z])
    return mesh.transformed(M.rotation_z(yaw + np.pi / 2 + extra_yaw), point + lift)


def render_street(
    rng: np.random.Generator,
    grid: ScanGrid | None = None,
    max_range_m: float = 120.0,
    sensor_height_m=(1.6, 2.0),
) -> StreetImage:
    """Render one procedural street scene as a range image with per-pixel labels.

    Args:
        rng: every random choice comes from it.
        grid: the scan grid; default ``default_grid()`` (64 x 256, 30 x 90 degrees).
        max_range_m: nothing beyond this range returns (sky, far terrain).
        sensor_height_m: (low, high) of the sensor's height above the road.
    """
    grid = default_grid() if grid is None else grid
    half_w = rng.uniform(3.5, 7.5)
    road = Road(
        offset_m=rng.uniform(-0.5, 0.5) * half_w,
        curvature_per_m=rng.uniform(-0.004, 0.004),
        half_width_m=half_w,
        sidewalk_m=rng.uniform(1.5, 4.0),
    )
    height = rng.uniform(*sensor_height_m)
    yaw = np.deg2rad(rng.uniform(-8, 8))
    pose = Pose.looking_at((0, 0, height), (np.sin(yaw), np.cos(yaw), height))

    meshes = []
    kerb = road.half_width_m
    for side in (-1, 1):
        if rng.random() < 0.8:  # a row of buildings
            setback = kerb + road.sidewalk_m + rng.uniform(0.0, 8.0)
            y = rng.uniform(-5, 15)
            while y < max_range_m:
                frontage = rng.uniform(8, 25)
                if rng.random() < 0.85:
                    b = building_block(rng, frontage)
                    meshes.append(
                        _on_road(
                            b,
                            road,
                            side * setback,
                            y + frontage / 2,
                            np.pi if side > 0 else 0.0,
                            CURB_HEIGHT_M,
                        )
                    )
                y += frontage + rng.uniform(0, 8)
        n_trees = rng.integers(0, 8)
        for y in np.sort(rng.uniform(4, 90, n_trees)):
            lat = side * (kerb + rng.uniform(0.3, road.sidewalk_m + 3.0))
            meshes.append(_on_road(tree(rng), road, lat, y, z=CURB_HEIGHT_M))
        if rng.random() < 0.3:
            y0 = rng.uniform(5, 40)
            length = rng.uniform(5, 20)
            meshes.append(
                _on_road(
                    bush(rng, length),
                    road,
                    side * (kerb + road.sidewalk_m + 0.5),
                    y0 + length / 2,
                    np.pi / 2,
                    CURB_HEIGHT_M,
                )
            )
        spacing = rng.uniform(15, 40)
        for y in np.arange(rng.uniform(3, spacing), 110, spacing):
            if rng.random() < 0.8:
                meshes.append(
                    _on_road(
                        pole(rng),
                        road,
                        side * (kerb + 0.4),
                        y,
                        np.pi / 2 if side > 0 else -np.pi / 2,
                        CURB_HEIGHT_M,
                    )
                )
        # Parked cars along the curb.
        y = rng.uniform(3, 12)
        while y < 80:
            if rng.random() < 0.45:
                meshes.append(
                    _on_road(
                        car(rng), road, side * (road.half_width_m - 1.1), y, rng.normal(0, 0.03)
                    )
                )
            y += rng.uniform(5.5, 9)
        for y in rng.uniform(3, 40, rng.integers(0, 5)):
            person = human(rng)
            person.label[:] = PEDESTRIAN
            lat = side * (kerb + rng.uniform(0.3, road.sidewalk_m - 0.3))
            meshes.append(_on_road(person, road, lat, y, rng.uniform(0, 2 * np.pi), CURB_HEIGHT_M))
    # Traffic in the lanes.
    for y in rng.uniform(6, 100, rng.integers(0, 6)):
        lane = rng.choice([-1, 1]) * road.half_width_m / 2
        meshes.append(_on_road(car(rng), road, lane, y, 0.0 if lane > 0 else np.pi))
    if rng.random() < 0.3:  # someone crossing
        person = human(rng)
        person.label[:] = PEDESTRIAN
        meshes.append(
            _on_road(
                person,
                road,
                rng.uniform(-half_w, half_w),
                rng.uniform(5, 30),
                rng.uniform(0, 2 * np.pi),
            )
        )

    hits = _ground(grid, pose, road, rng)
    if meshes:
        hits = hits.nearest(cast_mesh(grid, pose, M.merge(meshes)))
    valid = np.isfinite(hits.range_m) & (hits.range_m <= max_range_m)
    labels = np.where(valid, hits.label, IGNORE_INDEX).astype(np.uint8)
    return StreetImage(
        np.where(valid, hits.range_m, np.nan).astype(np.float32),
        np.where(valid, hits.albedo * hits.cos_incidence, 0.0).astype(np.float32),
        valid,
        labels,
    )


def range_image_to_points(depth_m: np.ndarray, grid: ScanGrid) -> np.ndarray:
    """(rows, cols, 3) sensor-frame points x, y, z of a range image (NaN where void).

    x = d cos(el) sin(az), y = d cos(el) cos(az), z = d sin(el): X right, Y forward, Z up.
    """
    depth = np.asarray(depth_m, dtype=np.float64)
    if depth.shape[-2:] != tuple(grid.shape):
        raise ValueError(
            f"depth_m has shape {depth.shape}, "
            f"expected (..., {grid.shape[0]}, {grid.shape[1]}) of the grid."
        )
    return depth[..., None] * grid.directions()
