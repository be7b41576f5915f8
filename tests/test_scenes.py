"""Procedural scenes: exact ray casting, the 11 categories, street scenes, learnability."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from spl_al.data.seeds import sample_rng
from spl_al.label_codes import IGNORE_INDEX
from spl_al.scenes import mesh as M
from spl_al.scenes import raycast
from spl_al.scenes.objects import CATEGORIES, render_object
from spl_al.scenes.raycast import Pose, ScanGrid, cast_mesh, cast_plane
from spl_al.scenes.street import STREET_CLASSES, range_image_to_points, render_street


def _sphere_range(grid, pose, centre, radius):
    """Analytic range to a sphere along every ray (inf where missed)."""
    d = grid.directions() @ pose.rotation.T
    oc = pose.position - np.asarray(centre)
    b = d @ oc
    disc = b * b - (oc @ oc - radius**2)
    return np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)


def test_mesh_sphere_matches_analytic_ray_sphere():
    grid = ScanGrid.square_pixels((48, 48), 30.0)
    pose = Pose.looking_at((0.3, -3.0, 0.8), (0, 0, 0))
    sphere = M.ellipsoid((0.5, 0.5, 0.5), 0.7, label=3, n_sides=48, n_rings=32)
    hits = cast_mesh(grid, pose, sphere)
    exact = _sphere_range(grid, pose, (0, 0, 0), 0.5)
    # Away from the silhouette (|sin| of incidence <= 0.9, so |cos| >= 0.43) the range error
    # is at most the facet sagitta r (1 - cos(dphi / 2) cos(dtheta / 2)) over that cosine.
    inner = _sphere_range(grid, pose, (0, 0, 0), 0.45)
    core = np.isfinite(inner)
    sagitta = 0.5 * (1 - np.cos(np.pi / 48) * np.cos(np.pi / 64))
    assert core.sum() > 300
    assert np.all(hits.label[core] == 3)
    assert np.max(np.abs(hits.range_m[core] - exact[core])) < sagitta / 0.43
    assert not np.isfinite(hits.range_m[~np.isfinite(exact)]).any()
    # Lambertian shading: cos of incidence is ~1 at the sphere's centre pixel.
    assert hits.cos_incidence[core].max() > 0.99


def test_candidate_boxes_miss_nothing(monkeypatch):
    """Per-triangle pixel boxes give the same hits as testing every ray against every face,
    also for faces behind and beside the sensor."""
    rng = np.random.default_rng(1)
    grid = ScanGrid((24, 40), (20.0, -20.0), (-60.0, 60.0))
    parts = [
        M.box((4.0, 0.5, 3.0), 0.5, center=(0.0, 0.5, 0.0)),  # straddles the sensor plane
        M.torus(0.6, 0.1, 0.4).transformed(M.rotation_z(0.7), (1.0, 3.0, 0.2)),
        M.tube(rng.normal(size=(6, 3)) + np.array([0.0, 5.0, 0.0]), 0.2, 0.3),
    ]
    mesh = M.merge(parts)
    pose = Pose(np.zeros(3), np.eye(3))
    fast = cast_mesh(grid, pose, mesh)
    rows, cols = grid.shape

    def every_pixel(grid_, tri):
        f = len(tri)
        return np.zeros(f, int), np.full(f, rows - 1), np.zeros(f, int), np.full(f, cols - 1)

    monkeypatch.setattr(raycast, "_pixel_boxes", every_pixel)
    brute = cast_mesh(grid, pose, mesh)
    assert np.isfinite(fast.range_m).sum() > 100
    np.testing.assert_array_equal(fast.range_m, brute.range_m)
    np.testing.assert_array_equal(fast.label, brute.label)


def test_plane_range_and_incidence():
    grid = ScanGrid.square_pixels((16, 16), 20.0, elevation_centre_deg=-30.0)
    pose = Pose(np.array([0.0, 0.0, 2.0]), np.eye(3))
    hits, points = cast_plane(grid, pose, point=(0, 0, 0), normal=(0, 0, 1), albedo=0.4, label=0)
    el = grid.elevation_rad[:, None]
    np.testing.assert_allclose(hits.range_m, 2.0 / np.sin(-el) * np.ones((1, 16)), rtol=1e-9)
    np.testing.assert_allclose(points[..., 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(hits.cos_incidence, np.sin(-el) * np.ones((1, 16)), rtol=1e-9)


@pytest.mark.parametrize(
    "bad", [((16, 16), (10.0, 20.0), (-5.0, 5.0)), ((16, 16), (10.0, -10.0), (-100, 100))]
)
def test_scan_grid_rejects_bad_angles(bad):
    with pytest.raises(ValueError, match="_deg must be"):
        ScanGrid(*bad)


@pytest.mark.parametrize("category", CATEGORIES)
def test_every_category_renders_a_varied_object(category):
    a = render_object(category, sample_rng(7, 0, 1), image_shape=(64, 64))
    b = render_object(category, sample_rng(7, 0, 2), image_shape=(64, 64))
    again = render_object(category, sample_rng(7, 0, 1), image_shape=(64, 64))
    for img in (a, b):
        assert img.depth_m.dtype == np.float32 and img.depth_m.shape == (64, 64)
        np.testing.assert_array_equal(img.valid, np.isfinite(img.depth_m))
        assert img.object_mask.sum() >= 20, "the object must be visible"
        assert not (img.object_mask & ~img.valid).any()
        assert np.nanmax(img.depth_m) <= 140.0 and np.nanmin(img.depth_m) > 0
        assert (img.reflectance[img.valid] > 0).all() and (img.reflectance[~img.valid] == 0).all()
    np.testing.assert_array_equal(a.depth_m, again.depth_m)
    assert not np.array_equal(a.object_mask, b.object_mask), "two seeds gave the same scene"


def test_distance_follows_target_size():
    dist = {
        c: np.median([render_object(c, sample_rng(3, 0, k), (24, 24)).distance_m for k in range(8)])
        for c in ("apple", "human", "building")
    }
    assert dist["apple"] < 1.0 < dist["human"] < 20.0 < dist["building"] < 140.0


@pytest.mark.parametrize("category", ["building", "apple", "ship"])
def test_object_size_m_scales_scene_and_distance_together(category):
    """A scaled object stands where it fills the same part of the frame: the image is
    the same with every range multiplied by the scale, whatever the category's own size."""
    kw = {"image_shape": (24, 24), "fov_deg": 10, "fill": (0.8, 0.8), "p_wall": 1.0}
    a, b = (
        render_object(category, np.random.default_rng(5), object_size_m=(s, s), **kw)
        for s in (3.0, 6.0)
    )
    assert a.object_mask.sum() > 20 and np.array_equal(a.valid, b.valid)
    np.testing.assert_allclose(b.depth_m[b.valid], 2 * a.depth_m[a.valid], rtol=1e-5)
    assert b.distance_m == pytest.approx(2 * a.distance_m)
    # A 3 m diagonal seen at 10 degrees stands within a few tens of metres, any category.
    assert 5 < a.distance_m < 40
    with pytest.raises(ValueError, match="object_size_m"):
        render_object(category, np.random.default_rng(5), object_size_m=(6, 3), **kw)


def test_street_scene_labels_align_with_returns():
    counts = np.zeros(256, int)
    for k in range(4):
        img = render_street(sample_rng(5, 0, k))
        assert img.labels.dtype == np.uint8 and img.labels.shape == (64, 256)
        np.testing.assert_array_equal(img.labels == IGNORE_INDEX, ~img.valid)
        np.testing.assert_array_equal(img.valid, np.isfinite(img.depth_m))
        d = img.depth_m[img.valid]
        assert d.min() > 1.0 and d.max() <= 120.0
        assert (img.labels[img.valid] < len(STREET_CLASSES)).all()
        assert (~img.valid[0]).any(), "the top row should see some sky"
        counts += np.bincount(img.labels.ravel(), minlength=256)
    present = {STREET_CLASSES[k] for k in np.flatnonzero(counts[: len(STREET_CLASSES)])}
    assert {"road", "sidewalk", "building", "car", "pole", "vegetation"} <= present


def test_range_image_to_points_keeps_range():
    img = render_street(sample_rng(5, 0, 9))
    grid = ScanGrid((64, 256), (8.0, -22.0), (-45.0, 45.0))
    xyz = range_image_to_points(img.depth_m, grid)
    v = img.valid
    np.testing.assert_allclose(np.linalg.norm(xyz[v], axis=1), img.depth_m[v], rtol=1e-5)
    # The road lies below the sensor (height 1.6-2.0 m) and ahead of it.
    road = xyz[img.labels == STREET_CLASSES.index("road")]
    assert np.all(road[:, 2] < -1.5) and np.all(road[:, 1] > 0)


def _shape_features(depth, mask, valid, grid=12):
    """Scale- and translation-normalised shape: relative depth and mask of a square crop
    around the object, resampled to grid x grid, plus the box's aspect ratio."""
    rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
    cy, cx = (rows[0] + rows[-1]) / 2, (cols[0] + cols[-1]) / 2
    half = max(rows[-1] - rows[0], cols[-1] - cols[0]) / 2 + 0.5
    ys = np.clip(np.round(cy + np.linspace(-half, half, grid)).astype(int), 0, depth.shape[0] - 1)
    xs = np.clip(np.round(cx + np.linspace(-half, half, grid)).astype(int), 0, depth.shape[1] - 1)
    rel = np.clip(np.where(valid, depth / np.median(depth[mask]) - 1, 1.0), -0.3, 0.3)
    aspect = (rows[-1] - rows[0] + 1) / (cols[-1] - cols[0] + 1)
    return np.concatenate([rel[np.ix_(ys, xs)].ravel(), mask[np.ix_(ys, xs)].ravel(), [aspect]])


def test_classes_are_learnable_from_shape_not_from_distance_and_size():
    """A small classifier on clean depth beats chance (1/11) by far, while one that
    sees only the object's mean depth and pixel count does clearly worse."""
    from sklearn.ensemble import ExtraTreesClassifier, RandomForestClassifier
    from sklearn.neural_network import MLPClassifier
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    n_per_class = 60
    shape_x, trivial_x, y = [], [], []
    for c, name in enumerate(CATEGORIES):
        for k in range(n_per_class):
            img = render_object(name, sample_rng(0, 0, c * 1000 + k), image_shape=(32, 32))
            m = img.object_mask
            trivial = [np.log(img.depth_m[m].mean()), np.log(m.sum())]
            shape_x.append(np.concatenate([_shape_features(img.depth_m, m, img.valid), trivial]))
            trivial_x.append(trivial)
            y.append(c)
    shape_x, trivial_x, y = np.array(shape_x), np.array(trivial_x), np.array(y)
    order = np.random.default_rng(0).permutation(len(y))
    tr, te = order[: int(0.7 * len(y))], order[int(0.7 * len(y)) :]

    shape_clf = ExtraTreesClassifier(500, random_state=0).fit(shape_x[tr], y[tr])
    shape_acc = (shape_clf.predict(shape_x[te]) == y[te]).mean()
    trivial_acc = max(
        (clf.fit(trivial_x[tr], y[tr]).predict(trivial_x[te]) == y[te]).mean()
        for clf in (
            RandomForestClassifier(300, min_samples_leaf=2, random_state=0),
            make_pipeline(StandardScaler(), MLPClassifier((32, 32), max_iter=2000, random_state=0)),
        )
    )
    assert shape_acc >= 0.75, f"shape classifier {shape_acc:.2f}"
    assert trivial_acc <= shape_acc - 0.15, f"depth+size {trivial_acc:.2f} vs shape {shape_acc:.2f}"


def _frame_cues(depth_m, valid):
    """What a frame says without its shape: distance statistics of its returns, how many
    pixels return and how many are void."""
    z = depth_m[valid]
    return [
        np.log(np.median(z)),
        np.log(z.mean()),
        np.log(np.percentile(z, 10)),
        np.log(np.percentile(z, 90)),
        valid.sum(),
        1.0 - valid.mean(),
    ]


@pytest.mark.parametrize("name, image_shape", [("real_cls", (32, 32)), ("synth_cls", (18, 32))])
def test_default_standins_are_told_apart_by_shape_not_by_distance_or_voids(name, image_shape):
    """The default config's stand-ins, observed through the photon engine: a classifier
    on the frame's non-shape cues (distance statistics, returning pixels, void fraction)
    stays at least 25 points below one that also sees the object's shape, so what a
    learner gains on them is shape, as on the real captures."""
    import yaml
    from sklearn.ensemble import ExtraTreesClassifier, RandomForestClassifier

    from spl_al.data import make_classification_dataset

    config = yaml.safe_load((Path(__file__).parents[1] / "config" / "config.yaml").read_text())
    synthesis = {**config["datasets"][name]["synthesis"], "n_per_class": 40}
    d = make_classification_dataset(**{**synthesis, "image_shape": image_shape}, workers=1)
    cues = np.array([_frame_cues(d.depth_m[i], d.valid[i]) for i in range(len(d))])
    # The object's returns locate the crop (a few low-photon frames lose them all).
    mask = [m if m.any() else v for m, v in zip(d.object_mask & d.valid, d.valid, strict=True)]
    shape = np.array(
        [
            np.concatenate([_shape_features(d.depth_m[i], mask[i], d.valid[i]), cues[i]])
            for i in range(len(d))
        ]
    )
    tr, te, y = d.train_idx, d.test_idx, d.labels
    cue_clf = RandomForestClassifier(300, min_samples_leaf=2, random_state=0)
    cue_acc = (cue_clf.fit(cues[tr], y[tr]).predict(cues[te]) == y[te]).mean()
    shape_clf = ExtraTreesClassifier(500, random_state=0).fit(shape[tr], y[tr])
    shape_acc = (shape_clf.predict(shape[te]) == y[te]).mean()
    assert cue_acc <= shape_acc - 0.25, f"{name}: cues {cue_acc:.2f} vs shape {shape_acc:.2f}"
