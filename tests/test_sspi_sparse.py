"""SSPI's sparse layers against dense references (masked dense conv3d), layer by layer."""

from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F

from spl_al.photon.sspi.network import dilate_sites
from spl_al.photon.sspi.sparse import (
    SiteIndex,
    SparseTensor,
    apply_rulebook,
    conv_weight,
    strided_rulebook,
    submanifold_rulebook,
)

DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
TOL = {"atol": 1e-5, "rtol": 1e-5}


def random_sparse(shape, channels, density, seed, device="cpu") -> SparseTensor:
    """Random sites of a (D, H, W) grid with (N, channels) float64 features."""
    gen = torch.Generator().manual_seed(seed)
    mask = torch.rand(shape, generator=gen) < density
    coords = mask.nonzero()
    features = torch.randn((coords.shape[0], channels), generator=gen, dtype=torch.float64)
    return SparseTensor(coords.to(device), features.to(device), tuple(shape))


def random_weight(c_in, c_out, seed, device="cpu"):
    """spconv 2.x layout (C_out, 3, 3, 3, C_in) and a bias."""
    gen = torch.Generator().manual_seed(seed)
    weight = torch.randn((c_out, 3, 3, 3, c_in), generator=gen, dtype=torch.float64)
    bias = torch.randn((c_out,), generator=gen, dtype=torch.float64)
    return weight.to(device), bias.to(device)


def torch_weight(spconv_weight):
    """(C_out, C_in, 3, 3, 3) for F.conv3d from the spconv layout."""
    return spconv_weight.permute(0, 4, 1, 2, 3)


def at_sites(dense, coords):
    """(N, C) values of a (C, D, H, W) dense tensor at (N, 3) sites."""
    return dense[:, coords[:, 0], coords[:, 1], coords[:, 2]].T


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_submanifold_conv_equals_dense_conv_at_active_sites(seed, device):
    x = random_sparse((7, 6, 9), 3, 0.3, seed, device)
    weight, bias = random_weight(3, 4, seed + 10, device)
    sparse = apply_rulebook(
        x.features, submanifold_rulebook(x), weight=conv_weight(weight), bias=bias
    )
    dense = F.conv3d(x.to_dense()[None], torch_weight(weight), bias, padding=1)[0]
    assert sparse.shape == (x.coords.shape[0], 4)
    torch.testing.assert_close(sparse, at_sites(dense, x.coords), **TOL)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize(("shape", "seed"), [((7, 6, 9), 0), ((8, 8, 8), 1), ((11, 5, 6), 2)])
def test_strided_conv_equals_dense_conv_on_the_sites_it_creates(shape, seed, device):
    x = random_sparse(shape, 2, 0.15, seed, device)
    weight, bias = random_weight(2, 3, seed + 10, device)
    coords, out_shape, book, _ = strided_rulebook(x)
    sparse = apply_rulebook(x.features, book, weight=conv_weight(weight), bias=bias)

    dense = F.conv3d(x.to_dense()[None], torch_weight(weight), bias, stride=2, padding=1)[0]
    assert tuple(dense.shape[1:]) == out_shape
    # Output sites: every cell some active input reaches through the kernel.
    reach = F.conv3d(
        _indicator(x)[None],
        torch.ones((1, 1, 3, 3, 3), dtype=torch.float64, device=device),
        stride=2,
        padding=1,
    )[0, 0]
    assert torch.equal(coords, reach.nonzero())
    torch.testing.assert_close(sparse, at_sites(dense, coords), **TOL)


def _indicator(x: SparseTensor) -> torch.Tensor:
    """(1, D, H, W) float64 1 at active sites."""
    mark = torch.zeros((1, *x.shape), dtype=torch.float64, device=x.coords.device)
    mark[0, x.coords[:, 0], x.coords[:, 1], x.coords[:, 2]] = 1.0
    return mark


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize(("shape", "seed"), [((7, 6, 9), 0), ((8, 8, 8), 1), ((11, 5, 6), 2)])
def test_inverse_conv_equals_transposed_conv_at_the_strided_inputs(shape, seed, device):
    x = random_sparse(shape, 2, 0.15, seed, device)
    coords, out_shape, _, inverse = strided_rulebook(x)
    gen = torch.Generator().manual_seed(seed + 20)
    y = torch.randn((coords.shape[0], 3), generator=gen, dtype=torch.float64).to(device)
    weight, bias = random_weight(3, 2, seed + 30, device)
    sparse = apply_rulebook(y, inverse, weight=conv_weight(weight), bias=bias)

    y_dense = SparseTensor(coords, y, out_shape).to_dense()[None]
    pad = [d - ((m - 1) * 2 - 2 + 3) for d, m in zip(shape, out_shape, strict=True)]
    dense = F.conv_transpose3d(
        y_dense, weight.permute(4, 0, 1, 2, 3), bias, stride=2, padding=1, output_padding=pad
    )[0]
    assert sparse.shape == (x.coords.shape[0], 2)
    torch.testing.assert_close(sparse, at_sites(dense, x.coords), **TOL)


def test_site_index_finds_rows_and_rejects_outside_and_inactive():
    x = random_sparse((5, 4, 3), 1, 0.5, 3)
    index = SiteIndex(x.coords, x.shape)
    perm = torch.randperm(x.coords.shape[0], generator=torch.Generator().manual_seed(0))
    assert torch.equal(index.find(x.coords[perm]), perm)
    inactive = (~_indicator(x)[0].bool()).nonzero()
    outside = torch.tensor([[-1, 0, 0], [5, 0, 0], [0, 4, 0], [0, 0, 3]])
    assert (index.find(torch.cat((inactive, outside))) == -1).all()


def test_dilation_equals_dense_max_pool():
    x = random_sparse((30, 12, 13), 1, 0.01, 4)
    dilated = dilate_sites(x.coords, x.shape, bins=3, pixels=4)
    pooled = F.max_pool3d(_indicator(x)[None], (7, 9, 9), stride=1, padding=(3, 4, 4))[0, 0]
    expected = pooled.nonzero()
    assert torch.equal(dilated, expected)  # both sorted row-major
