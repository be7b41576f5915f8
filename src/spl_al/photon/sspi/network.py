"""SSPI (Yao et al., Optics Express 30(21) 2022): two sparse 3-D U-Nets and a dilation.

The photon-count cube of a frame is a sparse tensor over the grid (T, H, W) (time
first, as in the original, which feeds spconv a (1, T, H, W, 1) cube): its active
sites are the (bin, row, col) cells holding photons, its one feature the count.

1. Denoiser U-Net: logits (N, 1) at the input sites; sites with logit > 0 are kept
   as signal, with their raw counts (the original's ``mask = out.features > 0``).
2. Signal dilation: the kept sites grow by +-3 bins in time, then by +-4 pixels in
   rows and columns. The original does this with 3 + 4 stride-1 sparse convs of
   constant weight 1 (kernels (3,1,1) then (1,3,3)) and keeps cells > 0; since
   counts are positive that is exactly the box dilation computed here as a set of
   coordinates, clipped to the grid.
3. Depth U-Net (same architecture, its own weights) over the dilated sites, whose
   feature is the raw count there (0 where a dilated cell has no photon; the
   original adds 1 before ``from_dense`` and subtracts it again inside the net).
   Its output is one score per site.
4. Depth: per pixel, the arg-max over time of the scores. The original densifies
   the scores, puts -20 at inactive cells and takes ``torch.max`` over T (a
   softmax-based "peak compensation" exists there only as commented-out code);
   here the arg-max runs over a pixel's active sites only, and a pixel without
   active sites, or whose best score is below -20, is a void (the original would
   report bin 0 there).

Both U-Nets (``SparseUNet``): 8 channels, three strided downsamplings (kernel 3,
stride 2, padding 1) and their inverses, residual blocks of pre-activation
(BatchNorm eps 1e-4, ReLU, submanifold conv) pairs, skip connections concatenated
as [skip, upsampled] before a residual block with a 16 -> 8 submanifold shortcut.
"""

from __future__ import annotations

import torch

from spl_al.photon.sspi.sparse import (
    Rulebook,
    SiteIndex,
    SparseTensor,
    apply_rulebook,
    batch_norm,
    conv_weight,
    linear_key,
    strided_rulebook,
    submanifold_rulebook,
)

CHANNELS = 8
DILATION_BINS = 3  # three (3, 1, 1) convs of weight 1
DILATION_PIXELS = 4  # four (1, 3, 3) convs of weight 1
VOID_SCORE = -20.0  # the original's fill value for inactive cells before the arg-max

# name -> (C_in, C_out, has_bias) of every conv, and name -> C of every batch norm.
_CONVS: dict[str, tuple[int, int, bool]] = {}
_NORMS: dict[str, int] = {}


def _residual_spec(name: str, c_in: int, c_out: int) -> None:
    _NORMS[f"{name}.conv_branch.0"] = c_in
    _CONVS[f"{name}.conv_branch.2"] = (c_in, c_out, True)
    _NORMS[f"{name}.conv_branch.3"] = c_out
    _CONVS[f"{name}.conv_branch.5"] = (c_out, c_out, True)
    if c_in != c_out:
        _CONVS[f"{name}.i_branch.0"] = (c_in, c_out, True)


def _build_spec() -> None:
    c = CHANNELS
    _CONVS["start_head.0"] = (1, 4, False)
    _NORMS["start_head.1"] = 4
    _CONVS["start_head.3"] = (4, c, False)
    _NORMS["start_head.4"] = c
    _CONVS["start_head.6"] = (c, c, False)
    for name in ("path0_0.0", "path1_0.0", "path2_0.0", "path3.0", "path3.1", "path0_1.1"):
        _residual_spec(name, c, c)
    for name in ("path2_1.0", "path1_1.0", "path0_1.0"):
        _residual_spec(name, 2 * c, c)
    for name in (
        "downsample0",
        "downsample1",
        "downsample2",
        "upsample2",
        "upsample1",
        "upsample0",
    ):
        _NORMS[f"{name}.0"] = c
        _CONVS[f"{name}.2"] = (c, c, True)
    _NORMS["end_tail.0"] = c
    _CONVS["end_tail.2"] = (c, c, False)
    _NORMS["end_tail.3"] = c
    _CONVS["end_tail.5"] = (c, 4, False)
    _NORMS["end_tail.6"] = 4
    _CONVS["end_tail.8"] = (4, 1, True)


_build_spec()


def expected_shapes() -> dict[str, tuple[int, ...]]:
    """Every state-dict entry of one SSPI U-Net and its shape (206 entries).

    Conv weights are in spconv 2.x layout (C_out, 3, 3, 3, C_in); batch norms carry
    weight, bias, running_mean, running_var and num_batches_tracked.
    """
    shapes: dict[str, tuple[int, ...]] = {}
    for name, (c_in, c_out, has_bias) in _CONVS.items():
        shapes[f"{name}.weight"] = (c_out, 3, 3, 3, c_in)
        if has_bias:
            shapes[f"{name}.bias"] = (c_out,)
    for name, c in _NORMS.items():
        for field in ("weight", "bias", "running_mean", "running_var"):
            shapes[f"{name}.{field}"] = (c,)
        shapes[f"{name}.num_batches_tracked"] = ()
    return shapes


class SparseUNet:
    """One SSPI U-Net in eval mode over a ``SparseTensor`` with one feature.

    Args:
        state: the checkpoint's ``state_dict`` (validated by ``weights.load_state``).
        device: where to compute.
    """

    def __init__(self, state: dict[str, torch.Tensor], device: torch.device | str = "cpu"):
        self.device = torch.device(device)
        self.weights = {
            name: conv_weight(state[f"{name}.weight"].float()).to(self.device) for name in _CONVS
        }
        self.biases = {
            name: state[f"{name}.bias"].float().to(self.device)
            for name, (_, _, has_bias) in _CONVS.items()
            if has_bias
        }
        self.norms = {
            name: {
                field: state[f"{name}.{field}"].float().to(self.device)
                for field in ("weight", "bias", "running_mean", "running_var")
            }
            for name in _NORMS
        }

    def _conv(self, name: str, features: torch.Tensor, book: Rulebook) -> torch.Tensor:
        return apply_rulebook(features, book, weight=self.weights[name], bias=self.biases.get(name))

    def _norm_relu(self, name: str, features: torch.Tensor) -> torch.Tensor:
        return torch.relu(batch_norm(features, self.norms[name]))

    def _residual(self, name: str, x: torch.Tensor, book: Rulebook) -> torch.Tensor:
        """conv(relu(bn(conv(relu(bn(x)))))) + shortcut(x), all submanifold."""
        h = self._conv(f"{name}.conv_branch.2", self._norm_relu(f"{name}.conv_branch.0", x), book)
        h = self._conv(f"{name}.conv_branch.5", self._norm_relu(f"{name}.conv_branch.3", h), book)
        shortcut = f"{name}.i_branch.0"
        return h + (self._conv(shortcut, x, book) if shortcut in self.weights else x)

    @torch.no_grad()
    def __call__(self, x: SparseTensor) -> torch.Tensor:
        """(N, 1) output score at each of the N input sites of ``x`` (features (N, 1))."""
        sites = [x]  # the site set of each level 0..3
        subm = [submanifold_rulebook(x)]
        down: list[Rulebook] = []
        up: list[Rulebook] = []
        for _ in range(3):
            coords, shape, forward, inverse = strided_rulebook(sites[-1])
            sites.append(SparseTensor(coords, coords.new_zeros((coords.shape[0], 0)), shape))
            subm.append(submanifold_rulebook(sites[-1]))
            down.append(forward)
            up.append(inverse)

        h = self._conv("start_head.0", x.features.float(), subm[0])
        h = self._conv("start_head.3", self._norm_relu("start_head.1", h), subm[0])
        h = self._conv("start_head.6", self._norm_relu("start_head.4", h), subm[0])
        skips = [self._residual("path0_0.0", h, subm[0])]
        for level in range(3):
            h = self._norm_relu(f"downsample{level}.0", skips[-1])
            h = self._conv(f"downsample{level}.2", h, down[level])
            if level < 2:
                skips.append(self._residual(f"path{level + 1}_0.0", h, subm[level + 1]))
        h = self._residual("path3.1", self._residual("path3.0", h, subm[3]), subm[3])
        for level in (2, 1, 0):
            h_up = self._norm_relu(f"upsample{level}.0", h)
            h_up = self._conv(f"upsample{level}.2", h_up, up[level])
            h = self._residual(f"path{level}_1.0", torch.cat((skips[level], h_up), 1), subm[level])
        h = self._residual("path0_1.1", h, subm[0])
        h = self._conv("end_tail.2", self._norm_relu("end_tail.0", h), subm[0])
        h = self._conv("end_tail.5", self._norm_relu("end_tail.3", h), subm[0])
        return self._conv("end_tail.8", self._norm_relu("end_tail.6", h), subm[0])


def dilate_sites(
    coords: torch.Tensor, shape, bins: int = DILATION_BINS, pixels: int = DILATION_PIXELS
) -> torch.Tensor:
    """Box dilation of (N, 3) (t, row, col) sites by +-``bins`` and +-``pixels``, clipped.

    Done one axis at a time on row-major linear keys (each step de-duplicates), so
    the work stays near the size of the result. Returns (M, 3) int64 unique sites
    sorted row-major.
    """
    t_bins, rows, cols = (int(s) for s in shape)
    key = torch.unique(linear_key(coords, shape))
    for stride, size, reach in (
        (rows * cols, t_bins, bins),
        (cols, rows, pixels),
        (1, cols, pixels),
    ):
        position = (key // stride) % size  # the coordinate along this axis
        delta = torch.arange(-reach, reach + 1, device=key.device)
        moved = position[:, None] + delta[None]
        inside = (moved >= 0) & (moved < size)
        key = torch.unique((key[:, None] + delta[None] * stride)[inside])
    return torch.stack((key // (rows * cols), (key // cols) % rows, key % cols), dim=1)


class SSPI:
    """The whole reconstruction: denoise, dilate, estimate, arg-max.

    Args:
        denoiser_state, estimator_state: the ``state_dict`` of ``ssunet1.pth`` and
            ``ssunet2.pth``.
        device: where to compute (CPU or CUDA; the same code runs on both).
        cpu_threads: torch threads while a frame runs on CPU (restored after). One by
            default: the gathers are memory-bound, and on a shared or busy machine
            more threads cost more than they give; parallelise over frames instead.
    """

    def __init__(
        self,
        denoiser_state,
        estimator_state,
        device: torch.device | str = "cpu",
        cpu_threads: int = 1,
    ):
        self.device = torch.device(device)
        self.cpu_threads = int(cpu_threads)
        self.denoiser = SparseUNet(denoiser_state, self.device)
        self.estimator = SparseUNet(estimator_state, self.device)

    def __call__(self, coords: torch.Tensor, counts: torch.Tensor, shape) -> dict:
        """Reconstruct one frame (see ``run``), single-threaded on CPU by default."""
        if self.device.type != "cpu":
            return self.run(coords, counts, shape)
        before = torch.get_num_threads()
        torch.set_num_threads(self.cpu_threads)
        try:
            return self.run(coords, counts, shape)
        finally:
            torch.set_num_threads(before)

    @torch.no_grad()
    def run(self, coords: torch.Tensor, counts: torch.Tensor, shape) -> dict:
        """Reconstruct one frame.

        Args:
            coords: (N, 3) int64 unique (bin, row, col) cells holding photons.
            counts: (N,) photons in each cell.
            shape: (T, H, W) of the cube.

        Returns:
            dict with ``depth_bin`` (H, W) int64 arg-max bin, -1 at voids;
            ``signal_sites`` (K, 3) the denoiser's kept cells; ``n_dilated`` (int).
        """
        t_bins, rows, cols = (int(s) for s in shape)
        coords = coords.to(self.device, torch.int64)
        counts = counts.to(self.device, torch.float32)
        depth_bin = torch.full((rows * cols,), -1, dtype=torch.int64, device=self.device)
        empty = {"depth_bin": depth_bin.reshape(rows, cols), "signal_sites": coords[:0]}
        if coords.shape[0] == 0:
            return {**empty, "n_dilated": 0}
        grid = (t_bins, rows, cols)
        logits = self.denoiser(SparseTensor(coords, counts[:, None], grid))[:, 0]
        signal = coords[logits > 0]
        if signal.shape[0] == 0:
            return {**empty, "n_dilated": 0}
        dilated = dilate_sites(signal, grid)
        found = SiteIndex(coords, grid).find(dilated)
        feature = torch.where(found >= 0, counts[found.clamp(min=0)], 0.0)
        score = self.estimator(SparseTensor(dilated, feature[:, None], grid))[:, 0]

        pixel = dilated[:, 1] * cols + dilated[:, 2]
        best = torch.full((rows * cols,), -torch.inf, device=self.device)
        best = best.scatter_reduce(0, pixel, score, reduce="amax")
        at_best = (score == best[pixel]) & (score >= VOID_SCORE)
        first_bin = torch.full((rows * cols,), t_bins, dtype=torch.int64, device=self.device)
        first_bin = first_bin.scatter_reduce(0, pixel[at_best], dilated[at_best, 0], reduce="amin")
        depth_bin = torch.where(first_bin < t_bins, first_bin, -1)
        return {
            "depth_bin": depth_bin.reshape(rows, cols),
            "signal_sites": signal,
            "n_dilated": int(dilated.shape[0]),
        }
