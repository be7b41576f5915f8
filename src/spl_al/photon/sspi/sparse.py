"""Sparse 3-D tensors and the layers of a sparse U-Net, in plain PyTorch.

A sparse tensor holds N active sites of a (D, H, W) grid with C features each. A
convolution with a k x k x k kernel is computed as a sum over the K = k^3 kernel
offsets: for offset k, gather the input features of the (input site, output site)
pairs that offset links, multiply by the (C_in, C_out) weight of that offset and
scatter-add into the outputs,

    y[o] = b + sum_k sum_{(i, o) in R_k} x[i] W_k,

where the rulebook R_k lists the pairs. The cost follows the number of pairs (at
most K N), never the D H W cells of the grid; the same code runs on CPU and CUDA.

Site lookups go through sorted linear keys (``torch.searchsorted``), so no dense
index grid is allocated either. The three layer kinds of SSPI (spconv semantics):

- submanifold conv (``SubMConv3d``): outputs are exactly the input sites,
  i = o + k - c with c the kernel centre (cross-correlation, as torch's conv3d);
- strided conv (``SparseConv3d``, stride s, padding p): i = s o - p + k; the output
  sites are every o in range that some active input reaches;
- inverse conv (``SparseInverseConv3d``): the rulebook of a strided conv read
  backwards, y[i] = b + sum_k sum_{(i, o) in R_k} x[o] W_k, producing features at
  exactly the strided conv's input sites (a transposed conv restricted to them).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class SparseTensor:
    """Active sites of one (D, H, W) grid (batch size 1).

    Attributes:
        coords: (N, 3) int64 site coordinates (d, h, w), unique.
        features: (N, C) float features of the sites.
        shape: (D, H, W) extent of the grid.
    """

    coords: torch.Tensor
    features: torch.Tensor
    shape: tuple[int, int, int]

    def replace(self, features: torch.Tensor) -> SparseTensor:
        """The same sites with new (N, C') features."""
        return SparseTensor(self.coords, features, self.shape)

    def to_dense(self) -> torch.Tensor:
        """(C, D, H, W) dense tensor, zeros at inactive cells (for tests and plots)."""
        dense = self.features.new_zeros((self.features.shape[1], *self.shape))
        d, h, w = self.coords.unbind(1)
        dense[:, d, h, w] = self.features.T
        return dense


def linear_key(coords: torch.Tensor, shape) -> torch.Tensor:
    """(N,) int64 row-major index of (N, 3) coordinates into a grid of ``shape``."""
    return (coords[:, 0] * shape[1] + coords[:, 1]) * shape[2] + coords[:, 2]


class SiteIndex:
    """Find the row of a coordinate among a tensor's active sites, via sorted keys."""

    def __init__(self, coords: torch.Tensor, shape):
        self.shape = tuple(int(s) for s in shape)
        self.sorted_key, self.order = torch.sort(linear_key(coords, self.shape))

    def find(self, coords: torch.Tensor) -> torch.Tensor:
        """(M,) int64 row of each of the (M, 3) ``coords``; -1 where inactive or outside."""
        bound = torch.tensor(self.shape, device=coords.device)
        inside = ((coords >= 0) & (coords < bound)).all(1)
        key = linear_key(coords.clamp(min=0), self.shape)
        pos = torch.searchsorted(self.sorted_key, key).clamp(
            max=max(self.sorted_key.numel() - 1, 0)
        )
        if self.sorted_key.numel() == 0:
            return torch.full_like(key, -1)
        hit = inside & (self.sorted_key[pos] == key)
        return torch.where(hit, self.order[pos], torch.full_like(key, -1))


@dataclass(frozen=True)
class Rulebook:
    """The (input row, output row) pairs a convolution links, grouped by kernel offset.

    Attributes:
        in_rows, out_rows: (P,) int64 pair rows, sorted by kernel offset.
        pairs_per_offset: K Python ints, how many pairs each offset has (sum = P).
        n_in, n_out: number of input and output sites.
    """

    in_rows: torch.Tensor
    out_rows: torch.Tensor
    pairs_per_offset: list[int]
    n_in: int
    n_out: int

    def inverse(self) -> Rulebook:
        """The same pairs with input and output swapped (for the inverse conv)."""
        return Rulebook(self.out_rows, self.in_rows, self.pairs_per_offset, self.n_out, self.n_in)


def kernel_offsets(kernel, device=None) -> torch.Tensor:
    """(K, 3) int64 offsets (a, b, c) of a kernel, row-major: k = (a kH + b) kW + c."""
    grid = itertools.product(*(range(int(k)) for k in kernel))
    return torch.tensor(list(grid), dtype=torch.int64, device=device).reshape(-1, 3)


def _rulebook_from_lists(in_rows, out_rows, n_in, n_out) -> Rulebook:
    counts = [int(r.numel()) for r in in_rows]
    return Rulebook(torch.cat(in_rows), torch.cat(out_rows), counts, n_in, n_out)


def submanifold_rulebook(x: SparseTensor, kernel=(3, 3, 3)) -> Rulebook:
    """Pairs of a submanifold conv: output site o reads input site o + k - c."""
    index = SiteIndex(x.coords, x.shape)
    offsets = kernel_offsets(kernel, x.coords.device)
    centre = torch.tensor([int(k) // 2 for k in kernel], device=x.coords.device)
    rows = torch.arange(x.coords.shape[0], device=x.coords.device)
    in_rows, out_rows = [], []
    for offset in offsets:
        found = index.find(x.coords + (offset - centre))
        hit = found >= 0
        in_rows.append(found[hit])
        out_rows.append(rows[hit])
    n = x.coords.shape[0]
    return _rulebook_from_lists(in_rows, out_rows, n, n)


def strided_output_shape(shape, kernel, stride, padding) -> tuple[int, int, int]:
    """Grid of a strided conv, floor((D + 2 p - k) / s) + 1 per axis (as torch's conv3d)."""
    return tuple(
        (int(d) + 2 * int(p) - int(k)) // int(s) + 1
        for d, k, s, p in zip(shape, kernel, stride, padding, strict=True)
    )


def strided_rulebook(x: SparseTensor, kernel=(3, 3, 3), stride=(2, 2, 2), padding=(1, 1, 1)):
    """Output sites and pairs of a (regular, site-creating) sparse conv.

    Input site i feeds output o through offset k when i = s o - p + k, i.e.
    o = (i + p - k) / s for integer o inside the output grid.

    Returns:
        (out_coords (M, 3) int64 sorted by linear key, out_shape, Rulebook).
    """
    device = x.coords.device
    out_shape = strided_output_shape(x.shape, kernel, stride, padding)
    s = torch.tensor(stride, device=device)
    p = torch.tensor(padding, device=device)
    bound = torch.tensor(out_shape, device=device)
    offsets = kernel_offsets(kernel, device)
    rows = torch.arange(x.coords.shape[0], device=device)
    cand_in, cand_key, cand_offset = [], [], []
    for k, offset in enumerate(offsets):
        numer = x.coords + p - offset
        o = torch.div(numer, s, rounding_mode="floor")
        ok = ((numer - o * s) == 0).all(1) & ((o >= 0) & (o < bound)).all(1)
        cand_in.append(rows[ok])
        cand_key.append(linear_key(o[ok], out_shape))
        cand_offset.append(torch.full((int(ok.sum()),), k, device=device))
    keys = torch.cat(cand_key)
    out_key, out_row = torch.unique(keys, sorted=True, return_inverse=True)
    out_coords = torch.stack(
        (
            out_key // (out_shape[1] * out_shape[2]),
            (out_key // out_shape[2]) % out_shape[1],
            out_key % out_shape[2],
        ),
        dim=1,
    )
    # Candidates were generated offset by offset, so they are already grouped by k.
    counts = [int(c.numel()) for c in cand_in]
    book = Rulebook(torch.cat(cand_in), out_row, counts, x.coords.shape[0], out_key.numel())
    return out_coords, out_shape, book


def conv_weight(spconv_weight: torch.Tensor) -> torch.Tensor:
    """(K, C_in, C_out) per-offset matrices from an spconv 2.x weight (C_out, kD, kH, kW, C_in)."""
    c_out, c_in = spconv_weight.shape[0], spconv_weight.shape[-1]
    return spconv_weight.reshape(c_out, -1, c_in).permute(1, 2, 0).contiguous()


def apply_rulebook(
    features: torch.Tensor, book: Rulebook, weight: torch.Tensor, bias: torch.Tensor | None = None
) -> torch.Tensor:
    """Gather / matmul / scatter: y[o] = b + sum_k sum_{(i, o) in R_k} x[i] W_k.

    Args:
        features: (n_in, C_in) input features.
        book: the pairs, grouped by kernel offset.
        weight: (K, C_in, C_out), see ``conv_weight``.
        bias: (C_out,) or None.

    Returns:
        (n_out, C_out) output features.
    """
    out = features.new_zeros((book.n_out, weight.shape[2]))
    ins = torch.split(book.in_rows, book.pairs_per_offset)
    outs = torch.split(book.out_rows, book.pairs_per_offset)
    for k, (i, o) in enumerate(zip(ins, outs, strict=True)):
        if i.numel():
            out.index_add_(0, o, features[i] @ weight[k])
    if bias is not None:
        out += bias
    return out


def batch_norm(features: torch.Tensor, params: dict, eps: float = 1e-4) -> torch.Tensor:
    """Eval-mode BatchNorm1d over (N, C) features with running statistics,
    y = (x - mean) / sqrt(var + eps) * gamma + beta (SSPI uses eps = 1e-4)."""
    scale = params["weight"] / torch.sqrt(params["running_var"] + eps)
    return (features - params["running_mean"]) * scale + params["bias"]
