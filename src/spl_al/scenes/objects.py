"""Procedural object scenes for SPL classification: the 11 categories of the DUIS
paper's released real dataset, rendered as a scanning SPL sees them.

Each category is a small generator of a triangle mesh built from analytic shapes
(``spl_al.scenes.mesh``) with real intra-class variation: shape parameters and
sub-types (a roadblock is a barricade, a cone or a concrete barrier; a bin is a
wheelie bin or a round street bin; a ship is a cargo ship, a motor yacht or a
sailing boat), pose and viewpoint, scale and material albedo.

Distance follows the target's size as in the paper's captures: the object fills a
random fraction (``fill``) of the frame, so a 20 m building stands ~100 m away and
an apple ~0.3 m. Apparent size is thus random within every class, and distance
only separates coarse size groups; the class is in the shape. With
``object_size_m`` every object is scaled to a physical size drawn independently of
its class (scale models, as a lab capture might use), so range says nothing about the
class at all: scaling a scene and its viewing distance together leaves the image
unchanged except for the sensor's fixed timing resolution.

Scene around the object, drawn identically for every class: a ground plane
(probability ``p_ground``) and a wall behind it (``p_wall``) at a distance relative
to the object's size. Beyond ``max_range_m`` nothing returns.

Object frame: origin at the centre of the ground contact, Z up, X along the
object's length (a bike's wheelbase, a ship's keel), metres.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from spl_al.scenes import mesh as M
from spl_al.scenes.raycast import Hits, Pose, ScanGrid, cast_mesh, cast_plane

CATEGORIES = (
    "building",
    "bike",
    "bin",
    "roadblock",
    "human",
    "ship",
    "fire_hydrant",
    "apple",
    "banana",
    "cap",
    "water_bottle",
)

OBJECT_LABEL = 1  # mesh label of object faces; 0 is the background (ground, wall)


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def _v(x: float, y: float, z: float) -> np.ndarray:
    return np.array([x, y, z], dtype=np.float64)


def _place_on_ground(mesh: M.Mesh) -> M.Mesh:
    """Shift the mesh so that its lowest point touches z = 0, centred in x and y."""
    lo, hi = mesh.bounds()
    return mesh.transformed(np.eye(3), [-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])


def _tilted(mesh: M.Mesh, tilt_rad: float, yaw_rad: float) -> M.Mesh:
    return mesh.transformed(M.rotation_z(yaw_rad) @ M.rotation_y(tilt_rad), np.zeros(3))


# -- categories ---------------------------------------------------------------------------


def building(rng: np.random.Generator) -> M.Mesh:
    """Block, tower with setback, house with gabled roof, or L-shaped block; window grid."""
    kind = rng.choice(["block", "tower", "house", "l_shape"], p=[0.3, 0.25, 0.25, 0.2])
    wall = _u(rng, 0.3, 0.7)
    glass = _u(rng, 0.02, 0.1)
    floor_h = _u(rng, 2.8, 3.6)
    if kind == "house":
        w, d, h = _u(rng, 5, 14), _u(rng, 5, 11), floor_h * rng.integers(1, 3)
    else:
        w, d, h = _u(rng, 8, 28), _u(rng, 8, 18), floor_h * rng.integers(2, 9)
    parts = [M.box((w, d, h), wall, center=(0, 0, h / 2))]
    facades = [(w, d, h, 0.0, 0.0)]  # (width, depth, height, x offset, z base)
    if kind == "house":
        roof_h = _u(rng, 0.3, 0.6) * d
        parts.append(
            M.prism(
                [(-d / 2 - 0.4, 0), (d / 2 + 0.4, 0), (0, roof_h)],
                w + 0.6,
                _u(rng, 0.1, 0.4),
                center=(0, 0, h),
            ).transformed(M.rotation_z(np.pi / 2), (0, 0, 0))
        )
        if rng.random() < 0.6:  # chimney
            parts.append(
                M.box(
                    (0.8, 0.8, roof_h),
                    wall,
                    center=(_u(rng, -w / 3, w / 3), d / 5, h + roof_h * 0.8),
                )
            )
    elif kind == "tower":
        w2, d2, h2 = w * _u(rng, 0.4, 0.7), d * _u(rng, 0.4, 0.8), floor_h * rng.integers(2, 6)
        x2 = _u(rng, -(w - w2) / 2, (w - w2) / 2)
        parts.append(M.box((w2, d2, h2), wall, center=(x2, 0, h + h2 / 2)))
        facades.append((w2, d2, h2, x2, h))
    elif kind == "l_shape":
        w2, d2 = w * _u(rng, 0.3, 0.5), d * _u(rng, 0.8, 1.5)
        h2 = h * _u(rng, 0.5, 1.0)
        x2 = (w - w2) / 2 * rng.choice([-1, 1])
        parts.append(M.box((w2, d2, h2), wall, center=(x2, d / 2 + d2 / 2 - 0.5, h2 / 2)))
        facades.append((w2, d2, h2, x2, 0.0))
    if kind in ("block", "l_shape") and rng.random() < 0.7:  # parapet and roof plant
        parts.append(
            M.box(
                (_u(rng, 2, 4), _u(rng, 2, 4), _u(rng, 1.5, 3)),
                wall * 0.8,
                center=(_u(rng, -w / 4, w / 4), 0, h + 1),
            )
        )
    win_w, win_h = _u(rng, 1.0, 2.2), _u(rng, 1.2, 1.8)
    for fw, fd, fh, fx, fz in facades:
        n_floors = int(fh // floor_h)
        zs = fz + floor_h * (np.arange(n_floors) + 0.55)
        for width, depth, rot in ((fw, fd, 0.0), (fd, fw, np.pi / 2)):
            n_cols = max(1, int(width // (win_w * 2)))
            xs = (np.arange(n_cols) - (n_cols - 1) / 2) * width / n_cols
            for side in (-1, 1):
                for x in xs:
                    for z in zs:
                        pane = M.box((win_w, 0.1, win_h), glass, center=(x, side * depth / 2, z))
                        parts.append(pane.transformed(M.rotation_z(rot), (fx, 0, 0)))
    return _place_on_ground(M.merge(parts))


def bike(rng: np.random.Generator) -> M.Mesh:
    """Bicycle: two tyres, diamond or step-through frame, fork, saddle, handlebar."""
    rw = _u(rng, 0.3, 0.36)
    base = _u(rng, 0.95, 1.12)
    tyre_r = _u(rng, 0.018, 0.03)
    tube_r = _u(rng, 0.014, 0.022)
    frame, rubber, metal = _u(rng, 0.2, 0.8), _u(rng, 0.06, 0.15), _u(rng, 0.3, 0.6)
    rear, front = np.array([-base / 2, 0, rw]), np.array([base / 2, 0, rw])
    bb = np.array([-base / 2 + _u(rng, 0.40, 0.46), 0, rw - _u(rng, 0.04, 0.08)])
    seat_top = bb + _v(-_u(rng, 0.12, 0.18), 0, _u(rng, 0.5, 0.62))
    head_top = front + _v(-_u(rng, 0.12, 0.2), 0, _u(rng, 0.45, 0.6))
    head_bot = head_top + (front - head_top) * 0.3
    step_through = rng.random() < 0.3
    top_end = bb + (seat_top - bb) * (0.45 if step_through else 0.95)
    parts = [
        M.torus(rw, tyre_r, rubber).transformed(np.eye(3), rear),
        M.torus(rw, tyre_r, rubber).transformed(np.eye(3), front),
        M.cylinder_between(bb, seat_top, tube_r, frame),
        M.cylinder_between(top_end, head_top if not step_through else head_bot, tube_r, frame),
        M.cylinder_between(bb, head_bot, tube_r * 1.2, frame),
        M.cylinder_between(head_bot, head_top, tube_r * 1.3, frame),
        M.cylinder_between(bb + _v(0, 0.04, 0), rear + _v(0, 0.05, 0), tube_r * 0.7, frame),
        M.cylinder_between(bb - _v(0, 0.04, 0), rear - _v(0, 0.05, 0), tube_r * 0.7, frame),
        M.cylinder_between(seat_top, rear + _v(0, 0.05, 0), tube_r * 0.7, frame),
        M.cylinder_between(seat_top, rear - _v(0, 0.05, 0), tube_r * 0.7, frame),
        M.cylinder_between(head_bot + _v(0, 0.05, 0), front + _v(0, 0.05, 0), tube_r * 0.8, frame),
        M.cylinder_between(head_bot - _v(0, 0.05, 0), front - _v(0, 0.05, 0), tube_r * 0.8, frame),
        M.cylinder_between(rear - _v(0, 0.06, 0), rear + _v(0, 0.06, 0), 0.03, metal),
        M.cylinder_between(front - _v(0, 0.06, 0), front + _v(0, 0.06, 0), 0.03, metal),
        M.cylinder_between(bb - _v(0, 0.07, 0), bb + _v(0, 0.07, 0), 0.09, metal * 0.8, n_sides=12),
    ]
    post_top = seat_top + _v(-0.02, 0, _u(rng, 0.05, 0.2))
    parts.append(M.cylinder_between(seat_top, post_top, tube_r * 0.8, metal))
    parts.append(
        M.ellipsoid((0.13, 0.07, 0.035), _u(rng, 0.05, 0.3)).transformed(
            np.eye(3), post_top + _v(0.02, 0, 0.03)
        )
    )
    stem_top = head_top + _v(_u(rng, -0.02, 0.06), 0, _u(rng, 0.04, 0.14))
    half_bar = _u(rng, 0.2, 0.3)
    parts.append(M.cylinder_between(head_top, stem_top, tube_r, metal))
    sweep = np.array([-_u(rng, 0.0, 0.12), 0, 0])
    bar = np.array(
        [
            stem_top + sweep + _v(0, -half_bar, 0),
            stem_top + _v(0, -0.05, 0),
            stem_top + _v(0, 0.05, 0),
            stem_top + sweep + _v(0, half_bar, 0),
        ]
    )
    parts.append(M.tube(bar, 0.014, metal, up=(0.0, 0.0, 1.0)))
    if rng.random() < 0.4:  # basket or rack
        spot = front + _v(0.05, 0, 0.35) if rng.random() < 0.5 else rear + _v(0, 0, 0.33)
        parts.append(
            M.box((0.3, 0.28, 0.22 if spot[0] > 0 else 0.03), _u(rng, 0.1, 0.5), center=spot)
        )
    # Children's bikes (16-20" wheels) up to large adult frames.
    return _place_on_ground(M.merge(parts).scaled(_u(rng, 0.6, 1.05)))


def bin_(rng: np.random.Generator) -> M.Mesh:
    """Wheelie bin (tapered box, lid, wheels) or round street bin (lathe, lid)."""
    plastic = _u(rng, 0.08, 0.5)
    if rng.random() < 0.55:
        h = _u(rng, 0.8, 1.25)  # 120 l to 360 l wheelie bins
        w, d = h * _u(rng, 0.5, 0.7), h * _u(rng, 0.55, 0.75)
        taper = _u(rng, 0.8, 0.92)
        rect = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
        rings = [
            np.column_stack([rect * [w * taper / 2, d * taper / 2], np.full(4, 0.05)]),
            np.column_stack([rect * [w / 2, d / 2], np.full(4, h - 0.05)]),
        ]
        lid_open = rng.random() < 0.15
        parts = [
            M.loft(np.array(rings), plastic, smooth=False),
            M.box(
                (w + 0.04, d + 0.06, 0.05), plastic * _u(rng, 0.7, 1.3), center=(0, 0.02, h - 0.025)
            ),
            M.cylinder_between(
                (-w / 2, d / 2 + 0.03, 0.1),
                (-w / 2 - 0.05, d / 2 + 0.03, 0.1),
                0.1,
                0.05,
                n_sides=12,
            ),
            M.cylinder_between(
                (w / 2, d / 2 + 0.03, 0.1), (w / 2 + 0.05, d / 2 + 0.03, 0.1), 0.1, 0.05, n_sides=12
            ),
            M.cylinder_between(
                (-w / 2 + 0.05, d / 2 + 0.08, h - 0.1),
                (w / 2 - 0.05, d / 2 + 0.08, h - 0.1),
                0.02,
                plastic,
            ),
        ]
        if lid_open:
            parts[1] = M.box(
                (w + 0.04, 0.05, d + 0.06), plastic, center=(0, d / 2 + 0.05, h + d / 2)
            )
    else:
        r, h = _u(rng, 0.16, 0.34), _u(rng, 0.5, 1.0)
        flare = _u(rng, 1.0, 1.15)
        z = np.linspace(0, h, 6)
        radius = r * np.linspace(1.0, flare, 6)
        parts = [M.lathe(radius, z, plastic, n_sides=20)]
        lid = rng.choice(["dome", "flat", "rim"])
        if lid == "dome":
            t = np.linspace(0, np.pi / 2, 5)
            parts.append(
                M.lathe(
                    r * flare * 1.03 * np.cos(t),
                    h + _u(rng, 0.1, 0.25) * r * np.sin(t),
                    plastic * 0.8,
                    n_sides=20,
                )
            )
        elif lid == "flat":
            parts.append(
                M.lathe(
                    [r * flare * 1.05, r * flare * 1.05], [h, h + 0.04], plastic * 0.8, n_sides=20
                )
            )
        else:
            parts.append(
                M.torus(r * flare, 0.025, 0.5).transformed(M.rotation_x(np.pi / 2), (0, 0, h))
            )
        if rng.random() < 0.4:  # on a post
            parts = [p.transformed(np.eye(3), (0, 0, 0.25)) for p in parts]
            parts.append(M.cylinder_between((0, 0, 0), (0, 0, 0.3), 0.04, 0.4))
    return _place_on_ground(M.merge(parts))


def roadblock(rng: np.random.Generator) -> M.Mesh:
    """Striped barricade on A-frame legs, traffic cone on a base, or concrete barrier."""
    kind = rng.choice(["barricade", "cone", "barrier"], p=[0.45, 0.3, 0.25])
    if kind == "barricade":
        w, h = _u(rng, 1.0, 1.8), _u(rng, 0.9, 1.2)
        n_boards = int(rng.integers(1, 4))
        board_h = _u(rng, 0.15, 0.25)
        bright, dark = _u(rng, 0.7, 0.95), _u(rng, 0.1, 0.3)
        n_stripes = int(rng.integers(4, 9))
        parts = []
        for k in range(n_boards):
            z = h - board_h / 2 - k * (board_h + _u(rng, 0.08, 0.2))
            for s in range(n_stripes):
                x = -w / 2 + (s + 0.5) * w / n_stripes
                parts.append(
                    M.box(
                        (w / n_stripes, 0.03, board_h), bright if s % 2 else dark, center=(x, 0, z)
                    )
                )
        splay = _u(rng, 0.15, 0.35)
        for x in (-w / 2 + 0.08, w / 2 - 0.08):
            for side in (-1, 1):
                parts.append(
                    M.cylinder_between(
                        (x, side * splay, 0), (x, 0.03 * side, h), 0.025, 0.5, n_sides=6
                    )
                )
    elif kind == "cone":
        h = _u(rng, 0.5, 0.95)
        base = _u(rng, 0.55, 0.7) * h
        rb, rt = 0.2 * h, 0.035 * h
        cuts = np.sort(rng.uniform(0.3, 0.85, 2))
        z = np.concatenate([[0.03], cuts * h, [h]])
        r = rb + (rt - rb) * (z - 0.03) / (h - 0.03)
        orange, white = _u(rng, 0.3, 0.6), _u(rng, 0.8, 0.95)
        parts = [M.box((base, base, 0.03), 0.1, center=(0, 0, 0.015))]
        for k in range(3):
            parts.append(
                M.lathe(r[k : k + 2], z[k : k + 2], white if k == 1 else orange, n_sides=16)
            )
    else:
        length, h = _u(rng, 1.5, 3.0), _u(rng, 0.8, 1.05)
        bottom, top = _u(rng, 0.5, 0.65), _u(rng, 0.15, 0.25)
        knee = _u(rng, 0.2, 0.35) * h
        profile = [
            (-bottom / 2, 0),
            (bottom / 2, 0),
            (bottom / 2 - 0.05, knee),
            (top / 2, h),
            (-top / 2, h),
            (-bottom / 2 + 0.05, knee),
        ]
        parts = [
            M.prism(profile, length, _u(rng, 0.35, 0.7)).transformed(
                M.rotation_z(np.pi / 2), (0, 0, 0)
            )
        ]
        if rng.random() < 0.5:  # reflector strip
            parts.append(M.box((length * 0.8, top + 0.02, 0.08), 0.95, center=(0, 0, h - 0.15)))
    return _place_on_ground(M.merge(parts))


def human(rng: np.random.Generator) -> M.Mesh:
    """Person standing or walking (gait phase, arm swing), sometimes waving or carrying a bag."""
    height = _u(rng, 1.1, 1.95)  # children to tall adults
    girth = _u(rng, 0.85, 1.25)
    shirt, trousers, skin = _u(rng, 0.1, 0.8), _u(rng, 0.05, 0.6), _u(rng, 0.25, 0.55)
    hip_z = 0.52 * height
    shoulder_z = 0.82 * height
    hip_w, shoulder_w = 0.09 * height * girth, 0.13 * height * girth
    swing = np.deg2rad(_u(rng, 0, 30)) * np.sin(_u(rng, 0, 2 * np.pi))
    leg = hip_z - 0.04
    parts = []
    for side, s in ((-1, 1.0), (1, -1.0)):
        thigh_ang, knee_bend = s * swing, max(0.0, -s * swing) * 1.2 + _u(rng, 0, 0.1)
        hip = np.array([side * hip_w * 0.6, 0, hip_z])
        knee = hip + 0.5 * leg * np.array([0, -np.sin(thigh_ang), -np.cos(thigh_ang)])
        shin = thigh_ang - knee_bend
        ankle = knee + 0.5 * leg * np.array([0, -np.sin(shin), -np.cos(shin)])
        toe = ankle + _v(0, -0.2 * height * 0.6, -0.02)
        r = 0.075 * height * girth * 0.55
        parts.append(
            M.tube(np.array([hip, knee, ankle]), [r * 1.15, r * 0.8, r * 0.55], trousers, n_sides=8)
        )
        parts.append(M.cylinder_between(ankle + _v(0, 0.03, -0.02), toe, 0.045, 0.08, n_sides=6))
    torso_z = np.linspace(hip_z - 0.05, shoulder_z + 0.02, 6)
    torso_w = hip_w * np.array([1.15, 1.1, 0.95, 1.05, 1.15, 0.9]) * 1.1
    torso_d = 0.11 * height * girth * np.array([0.9, 0.85, 0.8, 0.95, 0.9, 0.7]) * 0.55
    ang = 2 * np.pi * np.arange(12) / 12
    rings = np.stack(
        [
            np.column_stack([w * np.cos(ang) * s, d * np.sin(ang), np.full(12, z)])
            for w, d, z, s in zip(torso_w, torso_d, torso_z, [1, 1, 1, 1.2, 1.2, 1], strict=True)
        ]
    )
    parts.append(M.loft(rings, shirt))
    neck_top = np.array([0, 0, 0.88 * height])
    parts.append(M.cylinder_between((0, 0, shoulder_z), neck_top, 0.05, skin))
    head_r = 0.065 * height
    parts.append(
        M.ellipsoid((head_r * 0.85, head_r, head_r * 1.15), skin).transformed(
            np.eye(3), neck_top + _v(0, 0, head_r * 0.9)
        )
    )
    if rng.random() < 0.3:  # hat or hair volume
        parts.append(
            M.ellipsoid(
                (head_r * 0.95, head_r * 1.05, head_r * 0.6), _u(rng, 0.05, 0.6)
            ).transformed(np.eye(3), neck_top + _v(0, 0, head_r * 1.6))
        )
    wave = rng.random() < 0.15
    bag = rng.random() < 0.25
    arm = 0.34 * height
    for side, s in ((-1, -1.0), (1, 1.0)):
        shoulder = np.array([side * shoulder_w, 0, shoulder_z - 0.03])
        a = s * swing * 0.8
        if wave and side == 1:
            elbow = shoulder + 0.5 * arm * np.array([0.5, 0, 0.85])
            hand = elbow + 0.5 * arm * np.array([0.1, -0.2, 0.95])
        else:
            abduct = _u(rng, 0.05, 0.25)
            elbow = shoulder + 0.5 * arm * np.array([side * np.sin(abduct), -np.sin(a), -np.cos(a)])
            fore = a + _u(rng, 0.0, 0.5) * (1 if a < 0 else 0.3)
            hand = elbow + 0.5 * arm * np.array(
                [side * np.sin(abduct) * 0.5, -np.sin(fore), -np.cos(fore)]
            )
        r = 0.045 * height * girth * 0.6
        parts.append(
            M.tube(np.array([shoulder, elbow, hand]), [r * 1.1, r * 0.9, r * 0.7], shirt, n_sides=8)
        )
        parts.append(M.ellipsoid((0.035, 0.02, 0.05), skin).transformed(np.eye(3), hand))
        if bag and side == -1:
            parts.append(
                M.box(
                    (0.1, _u(rng, 0.25, 0.4), _u(rng, 0.25, 0.35)),
                    _u(rng, 0.1, 0.7),
                    center=hand + _v(0, 0, -0.15),
                )
            )
    return _place_on_ground(M.merge(parts))


def ship(rng: np.random.Generator) -> M.Mesh:
    """Cargo ship, motor yacht or sailing boat: hull above the waterline, superstructure."""
    kind = rng.choice(["cargo", "yacht", "sail"], p=[0.4, 0.35, 0.25])
    length = _u(rng, 18, 40) if kind == "cargo" else _u(rng, 6, 22)
    beam = length * _u(rng, 0.18, 0.28)
    freeboard = length * (_u(rng, 0.07, 0.1) if kind == "cargo" else _u(rng, 0.05, 0.08))
    hull_a, top_a = _u(rng, 0.15, 0.6), _u(rng, 0.5, 0.9)
    xs = np.linspace(-length / 2, length / 2, 14)
    s = (xs + length / 2) / length
    half_w = (
        beam
        / 2
        * np.clip(
            np.where(s > 0.6, np.sqrt(np.clip(1 - ((s - 0.6) / 0.4) ** 2, 0, 1)), 1.0), 0.02, 1
        )
    )
    half_w *= np.where(s < 0.1, 0.85 + 1.5 * s, 1.0)
    sheer = freeboard * (1 + 0.35 * np.clip((s - 0.5) * 2, 0, 1) ** 2)
    rake = np.where(s > 0.7, (s - 0.7) / 0.3, 0.0) * length * 0.06
    n_sec = 10
    t = np.linspace(0, np.pi, n_sec)
    rings = []
    for x, w, z_top, dx in zip(xs, half_w, sheer, rake, strict=True):
        # U-shaped section closed by the deck line: keel at z = 0 (the waterline).
        yy = -w * np.cos(t)
        zz = z_top * (1 - np.sin(t) ** 3 * 0.9)
        xx = x - dx * (1 - zz / max(z_top, 1e-9))
        rings.append(np.column_stack([xx, yy, zz]))
    parts = [M.loft(np.array(rings), hull_a)]
    deck = float(sheer.min())
    if kind == "cargo":
        bx = -length / 2 + length * _u(rng, 0.08, 0.15)
        levels = int(rng.integers(2, 5))
        for k in range(levels):
            lw = beam * (0.9 - 0.1 * k)
            parts.append(
                M.box(
                    (length * 0.1, lw, freeboard * 0.6),
                    top_a,
                    center=(bx, 0, deck + freeboard * 0.6 * (k + 0.5)),
                )
            )
        parts.append(
            M.cylinder_between(
                (bx - length * 0.06, 0, deck),
                (bx - length * 0.06, 0, deck + freeboard * levels * 0.7),
                beam * 0.1,
                _u(rng, 0.2, 0.6),
            )
        )
        n_stacks = int(rng.integers(0, 5))
        for k in range(n_stacks):
            cx = -length / 2 + length * (0.3 + 0.12 * k)
            hgt = freeboard * _u(rng, 0.3, 1.2)
            parts.append(
                M.box(
                    (length * 0.1, beam * 0.85, hgt),
                    _u(rng, 0.2, 0.8),
                    center=(cx, 0, deck + hgt / 2),
                )
            )
    elif kind == "yacht":
        cab_l = length * _u(rng, 0.35, 0.55)
        cx = -length * _u(rng, 0.0, 0.15)
        for k, frac in enumerate((1.0, 0.6)):
            hgt = freeboard * _u(rng, 0.5, 0.8)
            parts.append(
                M.prism(
                    [
                        (-cab_l * frac / 2, 0),
                        (cab_l * frac / 2 - hgt * 0.8, 0),
                        (cab_l * frac / 2 - hgt * 1.3, hgt),
                        (-cab_l * frac / 2, hgt),
                    ],
                    beam * 0.7,
                    top_a,
                    center=(cx, 0, deck + k * freeboard * 0.65),
                )
            )
    else:
        mast_h = length * _u(rng, 0.9, 1.3)
        mx = length * _u(rng, -0.05, 0.1)
        parts.append(M.cylinder_between((mx, 0, deck), (mx, 0, deck + mast_h), length * 0.008, 0.5))
        if rng.random() < 0.7:
            boom = length * _u(rng, 0.3, 0.45)
            parts.append(
                M.prism(
                    [
                        (mx - 0.05, deck + 1.0),
                        (mx - boom, deck + 1.0),
                        (mx - 0.05, deck + mast_h * 0.95),
                    ],
                    0.05,
                    _u(rng, 0.6, 0.9),
                )
            )
            parts.append(
                M.prism(
                    [
                        (mx + 0.05, deck + 0.8),
                        (length / 2 * 0.95, deck + 0.5),
                        (mx + 0.05, deck + mast_h * 0.9),
                    ],
                    0.05,
                    _u(rng, 0.6, 0.9),
                )
            )
        parts.append(
            M.box(
                (length * 0.2, beam * 0.5, freeboard * 0.5),
                top_a,
                center=(-length * 0.1, 0, deck + freeboard * 0.25),
            )
        )
    return _place_on_ground(M.merge(parts))


def fire_hydrant(rng: np.random.Generator) -> M.Mesh:
    """Pillar hydrant: flanged barrel, bonnet, operating nut, side and pumper nozzles."""
    h = _u(rng, 0.45, 1.1)
    r = h * _u(rng, 0.11, 0.17)
    paint = _u(rng, 0.3, 0.75)
    top = _u(rng, 0.68, 0.78)
    profile_r = np.array([1.45, 1.45, 1.0, 1.0, 1.3, 1.3, 1.15, 0.9, 0.45, 0.25, 0.25, 0.0]) * r
    profile_z = (
        np.array(
            [
                0.0,
                0.05,
                0.07,
                top,
                top + 0.01,
                top + 0.05,
                top + 0.07,
                top + 0.13,
                top + 0.19,
                top + 0.2,
                0.99,
                1.0,
            ]
        )
        * h
    )
    parts = [M.lathe(profile_r, profile_z, paint, n_sides=20)]
    nz = h * _u(rng, 0.45, 0.6)
    nr = r * _u(rng, 0.3, 0.4)
    for side in (-1, 1):
        parts.append(
            M.cylinder_between((side * r * 0.8, 0, nz), (side * r * 1.7, 0, nz), nr, paint)
        )
        parts.append(
            M.cylinder_between(
                (side * r * 1.7, 0, nz), (side * r * 1.85, 0, nz), nr * 1.3, paint * 0.8, n_sides=6
            )
        )
    if rng.random() < 0.6:
        parts.append(
            M.cylinder_between((0, -r * 0.8, nz * 0.95), (0, -r * 1.8, nz * 0.95), nr * 1.35, paint)
        )
    return _place_on_ground(M.merge(parts))


def apple(rng: np.random.Generator) -> M.Mesh:
    """Apple: wider-topped sphere with dimples at both poles, a stem, sometimes a leaf."""
    r = _u(rng, 0.03, 0.05)
    elong = _u(rng, 0.8, 1.05)
    taper = _u(rng, 0.0, 0.15)
    phi = np.linspace(0, np.pi, 16)
    radius = r * np.sin(phi) * (1 - taper * np.cos(phi))
    z = -r * elong * np.cos(phi)
    z -= r * _u(rng, 0.15, 0.35) * np.exp(-(((np.pi - phi) / 0.45) ** 2))
    z += r * _u(rng, 0.05, 0.2) * np.exp(-((phi / 0.4) ** 2))
    skin = _u(rng, 0.25, 0.65)
    top = float(z[-1])
    parts = [M.lathe(radius, z, skin, n_sides=20)]
    lean = rng.uniform(-0.3, 0.3, 2)
    stem_len = _u(rng, 0.01, 0.025)
    parts.append(
        M.cylinder_between(
            (0, 0, top - 0.005),
            (lean[0] * stem_len, lean[1] * stem_len, top + stem_len),
            0.0025,
            0.2,
            n_sides=5,
        )
    )
    if rng.random() < 0.3:
        parts.append(
            M.ellipsoid((0.025, 0.012, 0.002), 0.3).transformed(
                M.rotation_y(0.4), (0.02, 0, top + stem_len * 0.8)
            )
        )
    mesh = M.merge(parts)
    return _place_on_ground(_tilted(mesh, _u(rng, -0.4, 0.4), _u(rng, 0, 2 * np.pi)))


def banana(rng: np.random.Generator) -> M.Mesh:
    """Banana: tapered five-sided tube along an arc with a stalk, lying on its side or back."""
    arc = _u(rng, 0.13, 0.24)
    bend = _u(rng, 0.12, 0.25)  # radius of curvature
    r_max = _u(rng, 0.015, 0.021)
    s = np.linspace(0, 1, 16)
    ang = (s - 0.5) * arc / bend
    path = np.column_stack([bend * np.sin(ang), np.zeros_like(s), bend * (1 - np.cos(ang))])
    radius = r_max * (0.3 + 0.7 * np.sin(np.pi * np.clip(s * 1.05, 0, 1)) ** 0.5)
    peel = _u(rng, 0.4, 0.75)
    parts = [M.tube(path, radius, peel, n_sides=5, up=(0.0, 1.0, 0.0))]
    end = path[-1]
    stalk_dir = np.array([np.cos(ang[-1]), 0, np.sin(ang[-1])])
    parts.append(
        M.cylinder_between(
            end, end + stalk_dir * _u(rng, 0.015, 0.03), r_max * 0.35, peel * 0.6, n_sides=5
        )
    )
    mesh = M.merge(parts)
    roll = _u(rng, np.pi / 2 - 0.3, np.pi / 2 + 0.3) if rng.random() < 0.6 else _u(rng, -0.3, 0.3)
    mesh = mesh.transformed(M.rotation_x(roll), np.zeros(3))
    return _place_on_ground(mesh.transformed(M.rotation_z(_u(rng, 0, 2 * np.pi)), np.zeros(3)))


def cap(rng: np.random.Generator) -> M.Mesh:
    """Baseball cap: elliptic dome crown with a button and a curved brim."""
    a = _u(rng, 0.075, 0.105)
    b = a * _u(rng, 1.05, 1.2)
    h = _u(rng, 0.08, 0.12)
    fabric = _u(rng, 0.08, 0.8)
    t = np.linspace(0, np.pi / 2, 8)
    parts = [M.lathe(np.cos(t), h * np.sin(t), fabric, n_sides=24, scale_xy=(b, a))]
    parts.append(M.ellipsoid((0.008, 0.008, 0.005), fabric).transformed(np.eye(3), (0, 0, h)))
    brim_len = _u(rng, 0.06, 0.085)
    curve = _u(rng, 0.0, 0.5)
    ang = np.linspace(-np.pi / 2, np.pi / 2, 11)
    outline = np.column_stack([b * 0.85 + brim_len * np.cos(ang), a * 0.95 * np.sin(ang)])
    inner = np.column_stack([b * np.cos(ang * 0.75) * 0.98, a * np.sin(ang * 0.75) * 0.98])
    edge = np.concatenate([inner, outline[::-1]])
    droop = -curve * (edge[:, 1] / a) ** 2 * 0.03 - _u(rng, 0.0, 0.3) * np.clip(
        edge[:, 0] - b, 0, None
    )
    rings = np.stack([np.column_stack([edge, droop + 0.004]), np.column_stack([edge, droop])])
    parts.append(M.loft(rings, fabric * _u(rng, 0.7, 1.2), smooth=False))
    mesh = M.merge(parts)
    tilt = _u(rng, -0.5, 0.5) if rng.random() < 0.3 else 0.0
    return _place_on_ground(_tilted(mesh, tilt, _u(rng, 0, 2 * np.pi)))


def water_bottle(rng: np.random.Generator) -> M.Mesh:
    """Bottle: body (straight or waisted), shoulder, neck and cap; standing or lying."""
    h = _u(rng, 0.14, 0.36)  # 0.25 l to 2 l
    r = h * _u(rng, 0.11, 0.16)
    shoulder = _u(rng, 0.55, 0.75)
    neck_r = r * _u(rng, 0.35, 0.5)
    waist = _u(rng, 0.82, 1.0) if rng.random() < 0.5 else 1.0
    zf = np.array([0.0, 0.02, 0.3, 0.45, 0.6, shoulder, shoulder + 0.08, shoulder + 0.16, 0.88])
    rf = np.array([0.9, 1.0, 1.0, waist, 1.0, 1.0, 0.85, 0.6, neck_r / r])
    plastic, lid = _u(rng, 0.1, 0.5), _u(rng, 0.2, 0.8)
    parts = [
        M.lathe(rf * r, zf * h, plastic, n_sides=20),
        M.lathe([neck_r * 1.15, neck_r * 1.15], [0.88 * h, h], lid, n_sides=16),
    ]
    mesh = M.merge(parts)
    if rng.random() < 0.35:  # lying on its side
        mesh = mesh.transformed(M.rotation_y(np.pi / 2 + _u(rng, -0.1, 0.1)), np.zeros(3))
    return _place_on_ground(mesh.transformed(M.rotation_z(_u(rng, 0, 2 * np.pi)), np.zeros(3)))


BUILDERS: dict[str, Callable[[np.random.Generator], M.Mesh]] = {
    "building": building,
    "bike": bike,
    "bin": bin_,
    "roadblock": roadblock,
    "human": human,
    "ship": ship,
    "fire_hydrant": fire_hydrant,
    "apple": apple,
    "banana": banana,
    "cap": cap,
    "water_bottle": water_bottle,
}

# Categories whose outline is best seen broadside: the view azimuth stays within
# +-60 degrees of the side (either side), as a person photographing them would.
_SIDE_VIEW = {"bike", "ship", "roadblock"}


# -- rendering ----------------------------------------------------------------------------


@dataclass
class ObjectImage:
    """One rendered object scene; every image is (rows, cols).

    depth_m: float32 range along each pixel's ray, NaN where nothing returns.
    reflectance: float32 Lambertian intensity albedo * |cos incidence| * (d0 / d)^2
        (clipped to 4 near the sensor), 0 where nothing returns.
    valid: bool, True where a surface returns within ``max_range_m``.
    object_mask: bool, True on pixels whose return comes from the object.
    distance_m: range from the sensor to the object's centre.
    fill: fraction of the frame the object's larger angular extent was set to fill.
    """

    depth_m: np.ndarray
    reflectance: np.ndarray
    valid: np.ndarray
    object_mask: np.ndarray
    distance_m: float
    fill: float


@dataclass(frozen=True)
class ObjectView:
    """How an object scene is framed and what surrounds it (``render_object``'s options).

    image_shape: (rows, cols); pixels are square in angle, rows span ``fov_deg``.
    fov_deg: vertical field of view, degrees.
    max_range_m: nothing beyond this range returns (keep it inside the sensor's reach).
    fill: (low, high) of the fraction of the frame the object fills.
    elevation_deg: (low, high) of the viewing elevation above the object's centre.
    p_ground, p_wall: probabilities of a ground plane and of a wall behind the object.
    min_return: detection floor: pixels whose return albedo * |cos| * (d0 / d)^2 is
        below it give no return (far ground at grazing incidence, dark glass).
    azimuth_deg: with an instance rng, the view azimuth varies by +-azimuth_deg
        around the instance's resting orientation (None: any azimuth, or +-60
        degrees of broadside for bikes, ships and roadblocks).
    object_size_m: (low, high): scale the object (about its ground contact) so its
        bounding-box diagonal is drawn uniformly from this range, per instance
        (from the instance rng when given), whatever its category; None: the
        category's own size.
    """

    image_shape: tuple[int, int] = (64, 64)
    fov_deg: float = 30.0
    max_range_m: float = 140.0
    fill: tuple[float, float] = (0.3, 0.95)
    elevation_deg: tuple[float, float] = (2.0, 35.0)
    p_ground: float = 0.75
    p_wall: float = 0.3
    min_return: float = 0.05
    azimuth_deg: float | None = None
    object_size_m: tuple[float, float] | None = None

    def __post_init__(self):
        size = self.object_size_m
        if size is not None and not (len(size) == 2 and 0 < size[0] <= size[1]):
            raise ValueError(
                f"object_size_m must be (low, high) with 0 < low <= high, got {size!r}."
            )


def render_object(
    category: str,
    rng: np.random.Generator,
    image_shape=(64, 64),
    instance_rng: np.random.Generator | None = None,
    **view,
) -> ObjectImage:
    """Render one scene of ``category`` seen by a scanning SPL.

    Args:
        category: one of ``CATEGORIES``.
        rng: every random choice (shape, pose, view, scene) comes from it.
        image_shape: (rows, cols); pixels are square in angle, rows span ``fov_deg``.
        instance_rng: when given, the object's shape (and its resting orientation)
            come from it instead of ``rng``: samples sharing an instance_rng seed show
            one physical object, as a capture campaign films a few objects many times.
        **view: the other fields of ``ObjectView`` (``fov_deg``, ``max_range_m``,
            ``fill``, ``elevation_deg``, ``p_ground``, ``p_wall``, ``min_return``,
            ``azimuth_deg``, ``object_size_m``).
    """
    _check_category(category)
    return render_view(category, rng, ObjectView(image_shape=image_shape, **view), instance_rng)


def render_view(
    category: str,
    rng: np.random.Generator,
    view: ObjectView,
    instance_rng: np.random.Generator | None = None,
) -> ObjectImage:
    """``render_object`` with its options as one ``ObjectView``."""
    _check_category(category)
    shape_rng = rng if instance_rng is None else instance_rng
    obj = _build_object(category, shape_rng, view.object_size_m)
    lo, hi = obj.bounds()
    centre = (lo + hi) / 2
    size = float(np.linalg.norm(hi - lo))
    direction = _view_direction(category, rng, instance_rng, view)
    target_fill = _u(rng, *view.fill)
    grid = ScanGrid.square_pixels(view.image_shape, view.fov_deg)
    distance, pose = _frame(
        obj,
        centre,
        size=size,
        direction=direction,
        target_fill=target_fill,
        grid=grid,
        view=view,
        rng=rng,
    )
    hits = cast_mesh(grid, pose, obj)
    hits = _add_surroundings(
        hits, grid, pose=pose, centre=centre, size=size, direction=direction, view=view, rng=rng
    )
    return _finish(hits, distance, view.max_range_m, target_fill, view.min_return)


def _check_category(category: str) -> None:
    if category not in BUILDERS:
        raise ValueError(f"category must be one of {CATEGORIES}, got {category!r}.")


def _build_object(category: str, shape_rng: np.random.Generator, object_size_m) -> M.Mesh:
    """The object's mesh, scaled to ``object_size_m`` when given, labelled as the object."""
    obj = BUILDERS[category](shape_rng)
    if object_size_m is not None:
        lo, hi = obj.bounds()
        obj = obj.scaled(_u(shape_rng, *object_size_m) / float(np.linalg.norm(hi - lo)))
    obj.label = np.full(len(obj.faces), OBJECT_LABEL, dtype=np.int64)
    return obj


def _view_direction(category, rng, instance_rng, view: ObjectView) -> np.ndarray:
    """Unit vector from the object's centre towards the sensor."""
    if instance_rng is not None and view.azimuth_deg is not None:
        rest = -np.pi / 2 if category in _SIDE_VIEW else _u(instance_rng, 0, 2 * np.pi)
        view_az = rest + np.deg2rad(_u(rng, -view.azimuth_deg, view.azimuth_deg))
    elif category in _SIDE_VIEW:
        view_az = -np.pi / 2 + np.deg2rad(_u(rng, -60, 60)) + np.pi * rng.integers(0, 2)
    else:
        view_az = _u(rng, 0, 2 * np.pi)
    view_el = np.deg2rad(_u(rng, *view.elevation_deg))
    return np.array(
        [np.cos(view_el) * np.cos(view_az), np.cos(view_el) * np.sin(view_az), np.sin(view_el)]
    )


def _frame(obj, centre, *, size, direction, target_fill, grid, view: ObjectView, rng):
    """(distance_m, pose): the distance at which the object fills ``target_fill`` of the
    frame, and the sensor pose there, aimed off-centre."""
    # Angular extent at a far reference distance sets the distance for the target fill.
    ref = 20.0 * size
    pose = Pose.looking_at(centre + ref * direction, centre)
    local = pose.to_sensor(obj.vertices)
    ang_x = np.arctan2(local[:, 0], local[:, 1])
    ang_z = np.arctan2(local[:, 2], np.hypot(local[:, 0], local[:, 1]))
    rows, cols = grid.shape
    step = np.deg2rad(view.fov_deg) / rows
    extent = max(np.ptp(ang_x) / (cols * step), np.ptp(ang_z) / (rows * step))
    distance = min(ref * extent / target_fill, 0.7 * view.max_range_m)
    # Off-centre framing: aim at a point shifted by up to half the frame left free.
    slack = max(0.0, 1.0 - target_fill) / 2
    shift = rng.uniform(-slack, slack, 2) * np.array([cols, rows]) * step * distance
    pose = Pose.looking_at(centre + distance * direction, centre)
    aim = centre + shift[0] * pose.rotation[:, 0] + shift[1] * pose.rotation[:, 2]
    return distance, Pose.looking_at(centre + distance * direction, aim)


def _add_surroundings(hits, grid, *, pose, centre, size, direction, view: ObjectView, rng) -> Hits:
    """``hits`` with a ground plane (probability ``p_ground``) and a wall behind the
    object (probability ``p_wall``), the nearest surface winning each pixel."""
    if rng.random() < view.p_ground:
        ground, _ = cast_plane(
            grid, pose, point=(0, 0, 0), normal=(0, 0, 1), albedo=_u(rng, 0.03, 0.45), label=0
        )
        hits = hits.nearest(ground)
    if rng.random() < view.p_wall:
        back = np.array([-direction[0], -direction[1], 0.0])
        back = M.rotation_z(np.deg2rad(_u(rng, -30, 30))) @ (back / max(np.linalg.norm(back), 1e-9))
        wall_point = centre + back * size * _u(rng, 0.7, 3.0)
        wall, _ = cast_plane(
            grid, pose, point=wall_point, normal=-back, albedo=_u(rng, 0.2, 0.7), label=0
        )
        hits = hits.nearest(wall)
    return hits


def _finish(hits: Hits, distance_m: float, max_range_m: float, fill: float, min_return: float):
    hit = np.isfinite(hits.range_m) & (hits.range_m <= max_range_m)
    with np.errstate(divide="ignore", invalid="ignore"):
        falloff = np.where(hit, np.clip((distance_m / hits.range_m) ** 2, 0.0, 4.0), 0.0)
    intensity = hits.albedo * hits.cos_incidence * falloff
    valid = hit & (intensity >= min_return)
    depth = np.where(valid, hits.range_m, np.nan)
    reflectance = np.where(valid, intensity, 0.0)
    return ObjectImage(
        depth.astype(np.float32),
        reflectance.astype(np.float32),
        valid,
        valid & (hits.label == OBJECT_LABEL),
        float(distance_m),
        float(fill),
    )
