"""The dataset-source contract (``spl_al.data.sources.base``), checked for every
registered source on small inputs; a new source adds its cases to ``CASES``.

Each case makes a config entry (and, for captures, the folder of reconstructions the
workflow would make first). The contract: the entry builds a ``Dataset`` of its task
with a train and a test split and consistent fields; the same entry over the same
files saves the same bytes; a bad entry is a ValueError of one sentence.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from spl_al.data import LEVELS, Dataset, sources
from spl_al.experiment.data_steps import make_dataset

ROOT = Path(__file__).resolve().parents[1]
CLASSES = ("bike", "cone")
SYNTHESIS = {"n_per_class": 3, "image_shape": [16, 16], "workers": 1}


def release_folder(root: Path) -> Path:
    """A small folder in the authors' release layout: {class}_{NNNN}.npz."""
    rng = np.random.default_rng(0)
    root.mkdir(parents=True)
    for cls in CLASSES:
        for k in range(4):
            clean = 5.0 + rng.normal(0, 0.05, (20, 20))
            np.savez(
                root / f"{cls}_{k + 1:04d}.npz",
                depth_ssp=clean + rng.normal(0, 0.1, clean.shape),
                Z_true=clean,
            )
    return root


def reconstructed_captures(root: Path, labeled: bool) -> tuple[Path, Path]:
    """Six simulated captures (MSPPP 2, 5, 10; in class folders when ``labeled``) and the
    release-layout folder of their reconstructions (what rule captures_release makes)."""
    from helpers.photon_captures import simulate_capture, write_cube_npz
    from helpers.photon_scenes import disc_scene

    from spl_al.data.raw_captures import (
        CaptureOptions,
        capture_files,
        reconstruct_shard,
        write_release,
    )
    from spl_al.photon import SensorParams

    sensor = SensorParams(bin_width_s=80e-12, pulse_sigma_s=520e-12, n_bins=1024)
    scans = root / "scans"
    for j, msppp in enumerate((2.0, 5.0, 10.0) * 2):
        folder = scans / CLASSES[j // 3] if labeled else scans
        folder.mkdir(parents=True, exist_ok=True)
        events = simulate_capture(disc_scene(16, 16, 3.0, 6.0), msppp, 1.0, sensor, seed=j)
        write_cube_npz(folder / f"scan{j}.npz", events, sensor)
    options = CaptureOptions.from_dict({"shards": 1})
    reconstruct_shard(scans, capture_files(scans), out_path=root / "shard.npz", options=options)
    return scans, write_release([root / "shard.npz"], root / "release", options)


def seed_labels(root: Path) -> str:
    path = root / "seed.csv"
    path.write_text("file,label,split\nscan0.npz,bike,test\nscan4.npz,cone,test\n")
    return str(path)


def synthetic_cls(tmp):
    return {"task": "classification", "source": "synthetic", "synthesis": SYNTHESIS}, None


def synthetic_seg(tmp):
    synthesis = {"n_samples": 6, "image_shape": [8, 32], "workers": 1}
    return {"task": "segmentation", "source": "synthetic", "synthesis": synthesis}, None


def folder(tmp):
    path = release_folder(tmp / "release")
    entry = {"task": "classification", "source": "folder", "path": str(path)}
    return entry | {"synthesis": {"image_shape": [16, 16], "seed": 3}}, None


def folder_standin(tmp):
    entry = {"task": "classification", "source": "folder", "standin": True}
    return entry | {"synthesis": SYNTHESIS}, None


def unlabeled(tmp):
    _, release = reconstructed_captures(tmp, labeled=False)
    entry = {"task": "classification", "source": "unlabeled", "path": str(release)}
    return entry | {"classes": list(CLASSES), "seed_labels": seed_labels(tmp)}, None


def captures(tmp):
    scans, release = reconstructed_captures(tmp, labeled=True)
    entry = {"task": "classification", "source": "captures", "path": str(scans)}
    return entry | {"captures": {"shards": 1}}, release


def captures_human(tmp):
    scans, release = reconstructed_captures(tmp, labeled=False)
    entry = {"task": "classification", "source": "captures", "oracle": "human"}
    entry |= {"path": str(scans), "classes": list(CLASSES), "seed_labels": seed_labels(tmp)}
    return entry | {"captures": {"shards": 1}}, release


# source -> the makers of its good entries: (entry, release_dir) from a fresh folder
CASES = {
    "synthetic": [synthetic_cls, synthetic_seg],
    "folder": [folder, folder_standin],
    "unlabeled": [unlabeled],
    "captures": [captures, captures_human],
}

# source -> bad entries (given the folder of a good case's inputs) and their message
BAD = {
    "synthetic": [
        (lambda tmp: ({"task": "classification", "source": "synthetic"} | {
            "synthesis": {"n_per_class": 3, "image_shape": [3, 3]}}, None), "image_shape"),
    ],
    "folder": [
        (lambda tmp: ({"task": "classification", "source": "folder"}, None),
         r"no 'path' is given; set 'path' or 'standin: true'\."),
        (lambda tmp: ({"task": "classification", "source": "folder",
                       "path": str(tmp / "nowhere")}, None),
         r"nowhere does not exist \(config key 'path'\)\."),
    ],
    "unlabeled": [
        (lambda tmp: ({"task": "classification", "source": "unlabeled",
                       "path": str(tmp / "nowhere"), "classes": list(CLASSES)}, None),
         r"config key 'path': .*nowhere' is not a folder of depth files\."),
    ],
    "captures": [
        (lambda tmp: ({"task": "classification", "source": "captures",
                       "path": str(tmp)}, None),
         r"a captures dataset needs the folder of its reconstructions\."),
    ],
}  # fmt: skip


def case_params():
    return [
        pytest.param(name, make, id=f"{name}-{make.__name__}")
        for name in sources.names()
        for make in CASES.get(name, [None])
    ]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """(entry, release_dir, the saved dataset's path) of a case, made once per module."""
    cache = {}

    def build(make):
        if make.__name__ not in cache:
            tmp = tmp_path_factory.mktemp(make.__name__)
            entry, release = make(tmp)
            make_dataset(entry, tmp / "observed.npz", release_dir=release)
            cache[make.__name__] = entry, release, tmp / "observed.npz"
        return cache[make.__name__]

    return build


def test_every_source_has_cases_and_every_config_names_the_registry():
    assert set(CASES) == set(BAD) == set(sources.names()), (
        "a dataset source needs its cases in CASES and BAD of tests/test_sources.py"
    )
    schema = yaml.safe_load((ROOT / "config" / "schema.yaml").read_text())
    enum = schema["$defs"]["dataset"]["properties"]["source"]["enum"]
    assert sorted(enum) == sources.names(), "config/schema.yaml's source enum lists the registry"


@pytest.mark.parametrize(("name", "make"), case_params())
def test_source_contract(name, make, built):
    if make is None:
        pytest.skip(f"dataset source {name!r} has no case in tests/test_sources.py")
    entry, release, path = built(make)
    data = Dataset.load(path)
    n, h, w = data.depth_m.shape
    assert data.task == entry["task"] and n > 0 and data.depth_m.dtype == np.float32
    assert data.valid.shape == (n, h, w) and data.valid.dtype == bool
    assert data.labels.shape == ((n,) if data.task == "classification" else (n, h, w))
    assert set(data.split.tolist()) == {"train", "test"}
    assert set(data.level.tolist()) <= {*LEVELS, "unknown"}
    assert data.msppp.shape == data.sbr.shape == (n,)
    assert len(data.classes) >= 2 and len(np.unique(data.uid)) == n
    assert data.meta["synthetic_standin"] is (make is folder_standin)
    if "synthesis" in entry and "image_shape" in entry["synthesis"]:
        assert [h, w] == list(entry["synthesis"]["image_shape"])
    # the same entry over the same files saves the same bytes
    again = path.with_name("again.npz")
    assert make_dataset(entry, again, release_dir=release)["samples"] == n
    assert again.read_bytes() == path.read_bytes()


@pytest.mark.parametrize("name", sources.names())
def test_bad_entries_are_one_sentence(name, tmp_path):
    for make, message in BAD.get(name, []):
        entry, release = make(tmp_path)
        with pytest.raises(ValueError, match=message) as info:
            make_dataset(entry, tmp_path / "bad.npz", release_dir=release)
        text = str(info.value)
        assert "\n" not in text and text.endswith("."), text
        assert not (tmp_path / "bad.npz").exists()


def test_an_unknown_source_names_the_known_ones(tmp_path):
    entry = {"task": "classification", "source": "lidar_cloud"}
    with pytest.raises(ValueError) as info:
        make_dataset(entry, tmp_path / "x.npz")
    assert str(info.value) == (
        "config key 'source': 'lidar_cloud' is not a dataset source; expected one of "
        "captures, folder, synthetic, unlabeled."
    )


def test_register_refuses_a_taken_name_and_adds_a_new_one(monkeypatch):
    from spl_al.data.sources import base

    with pytest.raises(ValueError, match="'folder' is empty or already registered"):
        sources.register("folder")(lambda entry, *, release_dir=None: None)
    monkeypatch.setattr(base, "_REGISTRY", dict(base._REGISTRY))

    @sources.register("copy")
    def build(entry, *, release_dir=None):
        return sources.get("synthetic")(entry)

    assert "copy" in sources.names()
    data = sources.build_dataset({"task": "classification", "source": "copy"} | {
        "synthesis": SYNTHESIS})  # fmt: skip
    assert data.meta["synthetic_standin"] is False and len(data) == 33
