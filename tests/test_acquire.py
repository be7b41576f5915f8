"""spl_al.query with models spl-al does not ship: a classifier and a segmenter of the test's own.

The contract: ``budget`` distinct indices, none labeled, the same for the same seed;
DUIS runs ``predict`` on the frames' SIV variants too (more frames than the pool), and
picks otherwise than Random; a need ``predict`` cannot meet is refused in one sentence.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from torch import nn

import spl_al
from spl_al.acquire import Request, run

ROOT = Path(__file__).resolve().parents[1]
N, H, W, C = 30, 16, 16, 3
LABELED = [0, 4, 9]


class ClassifierNet(nn.Module):
    """A tiny CNN classifier: depth and validity in, class probabilities and features out."""

    def __init__(self) -> None:
        super().__init__()
        self.conv = nn.Conv2d(2, 8, 3, padding=1)
        self.fc = nn.Linear(8, C)

    def forward(self, depth, valid):
        x = torch.stack([torch.nan_to_num(depth) / 10.0, valid.float()], dim=1)
        f = torch.relu(self.conv(x)).mean(dim=(2, 3))
        return torch.softmax(self.fc(f), dim=1), f


class SegmenterNet(nn.Module):
    """A tiny per-pixel classifier: (B, C, H, W) probabilities and pooled features."""

    def __init__(self) -> None:
        super().__init__()
        self.conv = nn.Conv2d(2, 8, 3, padding=1)
        self.head = nn.Conv2d(8, C, 1)

    def forward(self, depth, valid):
        x = torch.stack([torch.nan_to_num(depth) / 10.0, valid.float()], dim=1)
        f = torch.relu(self.conv(x))
        return torch.softmax(self.head(f), dim=1), f.mean(dim=(2, 3))


class Counted:
    """``predict`` of a module: counts the frames it sees and the largest batch."""

    def __init__(self, net: nn.Module, features: bool = True):
        self.net, self.features = net.eval(), features
        self.frames, self.largest = 0, 0

    def __call__(self, depth_m, valid):
        assert depth_m.dtype == np.float32 and valid.dtype == bool
        assert np.isnan(depth_m[~valid]).all() and np.isfinite(depth_m[valid]).all()
        self.frames += len(depth_m)
        self.largest = max(self.largest, len(depth_m))
        with torch.no_grad():
            probs, feats = self.net(torch.from_numpy(depth_m), torch.from_numpy(valid))
        return (probs.numpy(), feats.numpy()) if self.features else probs.numpy()


def frames(seed: int = 0):
    """N depth frames: a tilted plane with a box in front, voids sprinkled in."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:H, 0:W]
    depth = np.empty((N, H, W), np.float32)
    for i in range(N):
        plane = rng.uniform(3, 8) + rng.uniform(-0.1, 0.1) * xx + rng.uniform(-0.1, 0.1) * yy
        r0, c0 = rng.integers(0, H - 6, 2)
        plane[r0 : r0 + 6, c0 : c0 + 6] -= rng.uniform(0.5, 2.0)
        depth[i] = plane
    valid = rng.random(depth.shape) > 0.1
    depth[~valid] = np.nan
    return depth, valid


def seeded(cls):
    """A module's class that builds the same weights every time."""

    def build():
        torch.manual_seed(0)
        return cls()

    return build


Classifier, Segmenter = seeded(ClassifierNet), seeded(SegmenterNet)
MODELS = {"classifier": Classifier, "segmenter": Segmenter}


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("method", ["duis", "margin", "random"])
def test_distinct_unlabeled_picks_the_same_for_the_same_seed(model, method):
    depth, valid = frames()
    picks = [
        spl_al.query(
            method, Counted(MODELS[model]()), depth, valid, labeled=LABELED, budget=5, seed=3
        )
        for _ in range(2)
    ]
    for p in picks:
        assert p.dtype == np.int64 and p.shape == (5,)
        assert len(set(p.tolist())) == 5 and not set(p.tolist()) & set(LABELED)
        assert p.min() >= 0 and p.max() < N
    np.testing.assert_array_equal(picks[0], picks[1])


@pytest.mark.parametrize("model", MODELS)
def test_duis_predicts_on_the_variants_and_picks_otherwise_than_random(model):
    depth, valid = frames()
    predict = Counted(MODELS[model]())
    duis = spl_al.query("duis", predict, depth, valid, labeled=LABELED, budget=6, seed=1)
    unlabeled = N - len(LABELED)
    assert predict.frames == 5 * unlabeled > N  # each frame and its M = 4 variants
    random_ = spl_al.query("random", predict, depth, valid, labeled=LABELED, budget=6, seed=1)
    assert set(duis.tolist()) != set(random_.tolist())


def test_batches_bound_predict_and_change_no_pick():
    depth, valid = frames()
    small, large = Counted(Classifier()), Counted(Classifier())
    kw = {"labeled": LABELED, "budget": 4, "seed": 2}
    a = run(Request("duis", small, depth, valid, batch_size=7, **kw)).indices
    b = spl_al.query("duis", large, depth, valid, **kw)  # 256 frames a call
    np.testing.assert_array_equal(a, b)
    assert small.largest <= 7 and small.frames == large.frames


@pytest.mark.parametrize(
    "method", ["entropy", "coreset", "badge", "typiclust", "probcover", "diversity", "maxherding"]
)
def test_every_strategy_runs_on_a_foreign_classifier(method):
    if method == "maxherding":
        pytest.importorskip("skactiveml")
    depth, valid = frames()
    p = spl_al.query(method, Counted(Classifier()), depth, valid, labeled=LABELED, budget=4)
    assert len(set(p.tolist())) == 4 and not set(p.tolist()) & set(LABELED)


@pytest.mark.parametrize("model", MODELS)
def test_variants_made_once_pick_as_the_query_makes_them(model):
    """make_variants at the query's seed, given to the query, changes no pick; the query
    then makes no variant; two processes make the same numbers as one."""
    depth, valid = frames()
    kw = {"labeled": LABELED, "budget": 5, "seed": 4}
    alone = spl_al.query("duis", Counted(MODELS[model]()), depth, valid, **kw)
    variants = spl_al.make_variants(depth, valid, seed=4)
    assert variants.shape == (N, 4, H, W) and variants.dtype == np.float32
    assert np.isnan(variants[~np.repeat(valid[:, None], 4, axis=1)]).all()
    predict = Counted(MODELS[model]())
    selection = run(Request("duis", predict, depth, valid, variants=variants, **kw))
    np.testing.assert_array_equal(selection.indices, alone)
    assert selection.seconds["variants"] == 0 and predict.frames == 5 * (N - len(LABELED))
    two = spl_al.make_variants(depth[:6], valid[:6], seed=4, n_jobs=2, chunk=4)
    np.testing.assert_array_equal(two, variants[:6])


def test_variants_of_other_frames_are_refused_in_one_sentence():
    depth, valid = frames()
    predict = Counted(Classifier())
    for variants in (np.zeros((N - 1, 4, H, W), np.float32), np.zeros((N, 4, H), np.float32)):
        with pytest.raises(
            ValueError, match=r"variants must be \(N, M, H, W\) = \(30, M, 16, 16\)"
        ) as err:
            run(Request("duis", predict, depth, valid, budget=3, variants=variants))
        one_sentence(str(err.value))
    with pytest.raises(ValueError, match=r"n_jobs must be an integer >= 1, got 0\.$"):
        spl_al.make_variants(depth, valid, n_jobs=0)


def test_without_features_duis_clusters_the_probabilities():
    depth, valid = frames()
    predict = Counted(Segmenter(), features=False)
    selection = run(
        Request("duis", predict, depth, valid, labeled=LABELED, budget=5, params={"n_cand": 10})
    )
    assert selection.task == "segmentation" and selection.frames_predicted == 5 * 27
    assert set(selection.seconds) == {"predict", "variants", "select", "total"}
    assert selection.seconds["variants"] > 0 and len(set(selection.indices.tolist())) == 5


def test_dropquery_reads_the_head_it_is_given():
    depth, valid = frames()
    net = Classifier()
    head = (net.fc.weight.detach().numpy(), net.fc.bias.detach().numpy(), 0.5)
    request = Request("dropquery", Counted(net), depth, valid, labeled=LABELED, budget=4, head=head)
    assert len(set(run(request).indices.tolist())) == 4


def one_sentence(message: str) -> None:
    assert message.endswith(".") and "\n" not in message
    assert len(re.findall(r"[.;] [A-Z]", message)) == 0, message


@pytest.mark.parametrize(
    ("method", "model", "features", "expected"),
    [
        ("badge", Classifier, False, r"badge needs features from predict .* probabilities only"),
        ("badge", Segmenter, True, r"per-pixel features \(B, D, H, W\) .* \(B, D\) features"),
        ("dropquery", Classifier, True, r"dropquery needs the classifier's last linear layer"),
        ("dropquery", Segmenter, True, r"for classification only"),
    ],
)
def test_a_need_predict_cannot_meet_is_refused_in_one_sentence(method, model, features, expected):
    depth, valid = frames()
    with pytest.raises(ValueError, match=expected) as err:
        spl_al.query(method, Counted(model(), features), depth, valid, labeled=LABELED, budget=3)
    one_sentence(str(err.value))


def test_bad_requests_are_refused_in_one_sentence():
    depth, valid = frames()
    predict = Counted(Classifier())
    cases = [
        ({"budget": 28}, r"budget 28 is more than the 27 unlabeled frames"),
        ({"budget": 0}, r"budget must be an integer >= 1"),
        ({"labeled": [3, 30]}, r"labeled must index the 30 frames"),
        ({"method": "nope"}, r"unknown strategy 'nope'"),
        ({"params": {"n_cand": 20}}, r'N_cand = 20 from 27 .*params\["n_cand"\] <= 13\.$'),
    ]
    for change, expected in cases:
        kw = {"method": "duis", "labeled": LABELED, "budget": 3, **change}
        method = kw.pop("method")
        with pytest.raises(ValueError, match=expected) as err:
            spl_al.query(method, predict, depth, valid, **kw)
        assert "\n" not in str(err.value)

    def logits(d, v):
        return np.random.default_rng(0).normal(size=(len(d), C))

    with pytest.raises(ValueError, match="must return probabilities") as err:
        spl_al.query("margin", logits, depth, valid, labeled=LABELED, budget=3)
    one_sentence(str(err.value))
    with pytest.raises(ValueError, match=r"expected \(8, C\) or \(8, C, 16, 16\)"):
        run(Request("margin", lambda d, v: np.ones(len(d)), depth, valid, budget=1, batch_size=8))


def test_import_spl_al_stays_cheap_and_query_is_the_acquire_function():
    from spl_al.acquire import make_variants, query

    assert spl_al.query is query and spl_al.make_variants is make_variants
    code = (
        "import sys, spl_al; print(sorted({'numpy', 'torch', 'spl_al.acquire'} & set(sys.modules)))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    )
    assert out.stdout.strip() == "[]"


def readme_example() -> str:
    """The Python block of the README's section "Use DUIS in your own code"."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## Use DUIS in your own code", 1)[1].split("\n## ", 1)[0]
    (code,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    return code


def test_the_readme_example_runs_as_written():
    code = readme_example()
    assert len(code.strip().splitlines()) <= 15
    assert "spl_al.models" not in code and "spl_al.query(" in code
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    picks = namespace["picks"]
    assert len(set(np.asarray(picks).tolist())) == len(picks) > 0


def test_small_pools_torch_outputs_and_a_0_1_mask_are_taken():
    """A pool of one unlabeled frame, predict answering in torch tensors (half precision)
    and a validity mask of 0/1 integers: DUIS still answers."""
    depth, valid = frames()
    net = Classifier()

    def predict(d, v):
        with torch.no_grad():
            probs, feats = net(torch.from_numpy(d), torch.from_numpy(v))
        return probs.half(), feats

    mask = valid.astype(np.int64)
    last = spl_al.query("duis", predict, depth, mask, labeled=range(N - 1), budget=1)
    np.testing.assert_array_equal(last, [N - 1])
    every = spl_al.query("duis", predict, depth, mask, labeled=None, budget=N)
    assert sorted(every.tolist()) == list(range(N))
