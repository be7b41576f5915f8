"""PointNet++ (Qi et al. 2017, single-scale grouping) for LiDAR point-cloud segmentation.

The network sees a range image as the point cloud of its valid returns and answers
per pixel, so it takes and returns what every segmenter here does and trains,
evaluates and scores through the same functions as the U-Net:

    forward(x): x (B, 2, H, W) = (range in metres, 0 at voids; validity 1/0),
                the input ``spl_al.models.model_input`` builds for a model whose
                ``input_kind`` is "range_m" (``to_range_input``)
             -> logits (B, C, H, W), features (B, d, H, W); zeros at void pixels.

Inside, per image (the pixel index of every point is kept by construction):

1. Points. Pixel p with range r(p) is the point xyz(p) = r(p) * u(p), u(p) the unit
   ray direction of its grid cell (``ScanGrid.directions``: X right, Y forward, Z up),
   with input features f(p) = (x, y, z, r) in metres, each channel standardised over
   the batch's points by a batch norm without learned scale or shift (``input_norm``;
   running statistics at evaluation), or (x, y, z, r) / coord_scale_m without it.
   Why: in a street scan x, y and r spread over tens of metres while z, which tells
   road from sidewalk and car roofs from walls, spreads over ~2 m; unscaled, its
   first-layer weights would learn far slower (README: PointNet++).
2. Sampling (``sample_pixels``): N = ``n_points`` of the valid pixels. Training: a
   uniformly random order of the valid pixels from the model's own seeded CPU
   generator (reset with the weights), its first N (without replacement); fewer than
   N valid pixels are cycled through that order again (resampling with replacement,
   every pixel used floor(N / n) or ceil(N / n) times). Evaluation: no randomness,
   N positions evenly spaced along the valid pixels in raster order
   (position floor(j * n / N), j = 0..N-1), so predictions do not depend on the batch.
3. The point network (``PointNet2Seg.point_forward``, permutation-equivariant):
   set abstraction levels k = 1..L, each
       centres  = farthest point sampling of S_k of the previous level's points
                  (``farthest_point_sample``, starting at the point farthest from the
                  centroid),
       groups   = for each centre its K nearest points within radius R_k
                  (``ball_query``; slots beyond the ball repeat the nearest point),
       feature  = max over the group of a shared MLP of
                  ((xyz_j - xyz_centre) / R_k, f_j)  (per point: linear, batch norm, ReLU);
   then feature propagation from the coarsest level back to the N points, each
       f_fine = MLP( concat( sum_{i in 3-NN} w_i f_coarse,i , f_fine_skip ) ),
       w_i = (1 / (d_i + eps)) / sum_{i'} (1 / (d_i' + eps))  (``three_nn_interpolate``).
4. Back to pixels: every valid pixel takes the same inverse-distance 3-NN
   interpolation of the N points' final features (a sampled pixel's nearest point is
   itself, weight ~1); a 1x1 linear head turns features into logits (linear, so it
   commutes with the interpolation). The features are what Coreset, BADGE and DUIS use.
5. Training (``training_outputs``) scores the N sampled points themselves by default
   (``loss_at="points"``, PointNet++'s own recipe): each step sees a fresh random
   sample of every cloud and skips step 4, which costs about a third of a CPU step.

No compiled extension: farthest point sampling is a numpy loop on the CPU and a torch
loop elsewhere (the same centres but where float rounding breaks an exact tie
differently); neighbour searches (``knn``) use scipy's cKDTree on the CPU and chunked
torch brute force on other devices (at most ``_CHUNK_ELEMENTS`` distances at once),
which agree up to ties in distance.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from spl_al.models.registry import register

# elements of a (batch, rows, points) distance block computed at once (float32: 64 MB)
_CHUNK_ELEMENTS = 1 << 24
_EPS_M = 1e-8


# ---------------------------------------------------------------- point operations


def square_distances(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """(B, S, 3), (B, N, 3) -> (B, S, N) squared Euclidean distances.

    |a|^2 + |b|^2 - 2 a.b (one batched matrix product), clamped at 0.
    """
    sq = (a * a).sum(-1)[..., None] + (b * b).sum(-1)[:, None, :]
    return torch.baddbmm(sq, a, b.transpose(1, 2), alpha=-2.0).clamp_min_(0.0)


def knn(
    query: torch.Tensor,
    ref: torch.Tensor,
    *,
    k: int,
    backend: str | None = None,
    within_m: float | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The k nearest ``ref`` points of every ``query`` point, nearest first, no gradient.

    Args:
        query: (B, P, 3); ref: (B, N, 3) with N >= k.
        backend: "kdtree", "torch", or None (kdtree on the CPU, torch elsewhere).
        within_m: if given, only neighbours at most this far are wanted: beyond the
            nearest one (always returned) the others may come back as distance inf
            and index N (the k-d tree then prunes its search, faster for small balls).

    Returns:
        squared distances (B, P, k) and indices (B, P, k) into ``ref``. On the CPU a
        scipy cKDTree per cloud (O(P log N)); elsewhere chunked brute force with
        ``torch.topk`` (at most ``_CHUNK_ELEMENTS`` distances at once). Both give the
        same neighbours (within ``within_m``) up to ties in distance.
    """
    b, p, _ = query.shape
    n = ref.shape[1]
    if not 1 <= k <= n:
        raise ValueError(f"k must be in [1, {n}] (the reference points), got {k}.")
    if backend is None:
        backend = "kdtree" if query.device.type == "cpu" else "torch"
    if backend not in ("kdtree", "torch"):
        raise ValueError(f"backend must be 'kdtree', 'torch' or None, got {backend!r}.")
    with torch.no_grad():
        if backend == "kdtree":
            from scipy.spatial import cKDTree

            q = query.detach().double().numpy()
            r = ref.detach().double().numpy()
            dist = np.empty((b, p, k))
            idx = np.empty((b, p, k), dtype=np.int64)
            # a hair past the radius, so that points exactly on it are kept as in torch
            bound = np.inf if within_m is None else float(within_m) * (1 + 1e-6) + 1e-9
            for i in range(b):
                tree = cKDTree(r[i])
                d_i, j_i = tree.query(q[i], k, distance_upper_bound=bound)
                d_i, j_i = d_i.reshape(p, k), j_i.reshape(p, k)
                lonely = j_i[:, 0] == n  # nothing within the bound: the nearest anyway
                if lonely.any():
                    d_l, j_l = tree.query(q[i][lonely], k)
                    d_i[lonely], j_i[lonely] = d_l.reshape(-1, k), j_l.reshape(-1, k)
                dist[i], idx[i] = d_i, j_i
            return (
                torch.from_numpy(dist**2).to(query.dtype).to(query.device),
                torch.from_numpy(idx).to(query.device),
            )
        # centred on the reference cloud's mean, then the k winners' distances are
        # recomputed as differences: the matrix-product form loses digits far away
        centre = ref.mean(dim=1, keepdim=True)
        q, r = query - centre, ref - centre
        rows = max(1, _CHUNK_ELEMENTS // max(1, b * n))
        idx = torch.cat(
            [
                torch.topk(square_distances(q[:, s : s + rows], r), k, dim=-1, largest=False)[1]
                for s in range(0, p, rows)
            ],
            dim=1,
        )
        d2 = ((q[:, :, None, :] - gather_points(r, idx)) ** 2).sum(-1)
        d2, order = torch.sort(d2, dim=-1, stable=True)
        return d2, torch.gather(idx, -1, order)


def farthest_point_sample(
    xyz: torch.Tensor, n_centres: int, backend: str | None = None
) -> torch.Tensor:
    """Farthest point sampling: (B, N, 3) points -> (B, S) indices of S = ``n_centres``.

    The first centre is the point farthest from the cloud's centroid; each next one
    maximises the distance to the nearest centre chosen so far,
        c_{k+1} = argmax_j min_{i <= k} ||x_j - x_{c_i}||^2,
    ties to the lowest index. Vectorised over the batch; S sequential iterations, so
    the cost is per-iteration overhead: ``backend`` "numpy" (the CPU default, a few
    in-place array operations per iteration, ~3x faster than torch's there) or
    "torch" (other devices), which give the same centres but where float rounding
    breaks an exact tie differently (each is deterministic).
    """
    b, n, _ = xyz.shape
    if not 1 <= n_centres <= n:
        raise ValueError(f"n_centres must be in [1, {n}], got {n_centres}.")
    if backend is None:
        backend = "numpy" if xyz.device.type == "cpu" else "torch"
    if backend not in ("numpy", "torch"):
        raise ValueError(f"backend must be 'numpy', 'torch' or None, got {backend!r}.")
    if backend == "numpy" and xyz.device.type != "cpu":
        raise ValueError(f"the numpy backend needs CPU points, got them on {xyz.device}.")
    with torch.no_grad():
        if backend == "numpy":
            return torch.from_numpy(_farthest_point_sample_numpy(xyz.detach().numpy(), n_centres))
        rows = torch.arange(b, device=xyz.device)
        out = torch.empty((b, n_centres), dtype=torch.long, device=xyz.device)
        centroid = xyz.mean(dim=1, keepdim=True)
        current = ((xyz - centroid) ** 2).sum(-1).argmax(dim=1)
        nearest = torch.full((b, n), float("inf"), dtype=xyz.dtype, device=xyz.device)
        for k in range(n_centres):
            out[:, k] = current
            d = ((xyz - xyz[rows, current][:, None, :]) ** 2).sum(-1)
            nearest = torch.minimum(nearest, d)
            current = nearest.argmax(dim=1)
    return out


def _farthest_point_sample_numpy(xyz: np.ndarray, n_centres: int) -> np.ndarray:
    """``farthest_point_sample`` on a (B, N, 3) array, coordinates as (3, B, N) planes."""
    b, n, _ = xyz.shape
    planes = np.ascontiguousarray(xyz.transpose(2, 0, 1))  # (3, B, N)
    flat = planes.reshape(3, -1)
    offsets = np.arange(b) * n
    out = np.empty((b, n_centres), dtype=np.int64)
    current = ((xyz - xyz.mean(axis=1, keepdims=True)) ** 2).sum(-1).argmax(axis=1)
    nearest = np.full((b, n), np.inf, dtype=xyz.dtype)
    d = np.empty((b, n), dtype=xyz.dtype)
    t = np.empty((b, n), dtype=xyz.dtype)
    for k in range(n_centres):
        out[:, k] = current
        centre = flat[:, offsets + current]  # (3, B)
        np.subtract(planes[0], centre[0][:, None], out=d)
        d *= d
        for axis in (1, 2):
            np.subtract(planes[axis], centre[axis][:, None], out=t)
            t *= t
            d += t
        np.minimum(nearest, d, out=nearest)
        current = nearest.argmax(axis=1)
    return out


def ball_query(
    xyz: torch.Tensor, centres: torch.Tensor, *, radius_m: float, k: int, backend: str | None = None
) -> torch.Tensor:
    """For each centre its ``k`` nearest points within ``radius_m``: (B, S, k) indices.

    Args:
        xyz: (B, N, 3) points; centres: (B, S, 3) query positions.
        backend: of ``knn``.

    Neighbours are ordered by distance; slots with no point left inside the ball
    (distance > radius_m, or k > N) repeat the nearest point (a centre taken from
    ``xyz`` is its own nearest point). Nearest-first instead of the original CUDA
    kernel's first-in-memory-order keeps the result independent of the order of
    the points.
    """
    n = xyz.shape[1]
    k_eff = min(k, n)
    d2, near = knn(centres, xyz, k=k_eff, backend=backend, within_m=radius_m)
    near = torch.where(d2 <= radius_m**2, near, near[..., :1])
    if k_eff < k:
        near = torch.cat([near, near[..., :1].expand(-1, -1, k - k_eff)], dim=-1)
    return near


def gather_points(values: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """values (B, N, F), idx (B, ...) -> (B, ..., F): values[b, idx[b, ...]]."""
    b = values.shape[0]
    flat = idx.reshape(b, -1)
    out = torch.gather(values, 1, flat[..., None].expand(-1, -1, values.shape[-1]))
    return out.reshape(*idx.shape, values.shape[-1])


def three_nn_interpolate(
    xyz_to: torch.Tensor,
    xyz_from: torch.Tensor,
    values_from: torch.Tensor,
    backend: str | None = None,
) -> torch.Tensor:
    """Inverse-distance interpolation from the 3 nearest points (PointNet++'s FP step).

    Args:
        xyz_to: (B, P, 3) where to interpolate; xyz_from: (B, S, 3) known points;
        values_from: (B, S, F) their values; backend: of ``knn``.

    Returns:
        (B, P, F): sum_i w_i v_i over the 3 nearest known points (fewer if S < 3),
        w_i = (1 / (d_i + eps)) / sum (1 / (d + eps)), d the Euclidean distance.
    """
    k = min(3, xyz_from.shape[1])
    d2, idx = knn(xyz_to, xyz_from, k=k, backend=backend)
    inv = 1.0 / (d2.sqrt() + _EPS_M)
    weight = (inv / inv.sum(-1, keepdim=True)).to(values_from.dtype)  # (B, P, k)
    return (gather_points(values_from, idx) * weight[..., None]).sum(-2)


def sample_pixels(
    valid: torch.Tensor, n_points: int, generator: torch.Generator | None
) -> torch.Tensor:
    """Fixed-size point sets from validity masks: (B, P) bool -> (B, N) pixel indices.

    ``generator`` given (training): a random order of each image's valid pixels, its
    first N; fewer than N valid pixels are cycled (j mod n). None (evaluation): the
    valid pixels in raster order at positions floor(j * n / N). An image with no
    valid pixel gets pixel 0 everywhere (its outputs are masked to zero anyway).
    """
    b, p = valid.shape
    if generator is None:
        key = torch.arange(p, device=valid.device, dtype=torch.float64)[None].expand(b, -1)
    else:
        key = torch.rand((b, p), generator=generator, dtype=torch.float64).to(valid.device)
    order = torch.argsort(torch.where(valid, key, key + 2.0 * p), dim=1, stable=True)
    n_valid = valid.sum(dim=1, keepdim=True).clamp_min(1)  # (B, 1)
    j = torch.arange(n_points, device=valid.device)[None]
    pos = j % n_valid if generator is not None else (j * n_valid) // n_points
    return torch.gather(order, 1, pos)


# ---------------------------------------------------------------- layers


class SharedMLP(nn.Module):
    """The same MLP on every point: (..., C_in) -> (..., C_out), channels last.

    Each layer is linear (no bias), batch norm over all points of the batch, ReLU: the
    1x1 convolutions of the original, written as matrix products on channel-last
    tensors, which on the CPU avoid a permute and the im2col path of a 1x1 conv.
    """

    def __init__(self, c_in: int, widths: list[int]):
        super().__init__()
        self.linears = nn.ModuleList()
        self.norms = nn.ModuleList()
        for c in widths:
            self.linears.append(nn.Linear(c_in, c, bias=False))
            self.norms.append(nn.BatchNorm1d(c))
            c_in = c

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        # weights saved before the MLPs were matrix products (1x1 convolutions in an
        # nn.Sequential of conv, batch norm, ReLU: keys "{3i}.weight", "{3i+1}.*") load
        for i in range(len(self.linears)):
            conv = f"{prefix}{3 * i}.weight"
            if conv in state_dict:
                weight = state_dict.pop(conv)
                state_dict[f"{prefix}linears.{i}.weight"] = weight.reshape(weight.shape[:2])
            for key in [k for k in state_dict if k.startswith(f"{prefix}{3 * i + 1}.")]:
                name = key[len(f"{prefix}{3 * i + 1}.") :]
                state_dict[f"{prefix}norms.{i}.{name}"] = state_dict.pop(key)
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """The shared MLP on the last axis: (..., C_in) -> (..., C_out)."""
        lead = x.shape[:-1]
        x = x.reshape(-1, x.shape[-1])
        for linear, norm in zip(self.linears, self.norms, strict=True):
            x = torch.relu(norm(linear(x)))
        return x.reshape(*lead, x.shape[-1])


class SetAbstraction(nn.Module):
    """One SA level: FPS centres, ball-query groups, shared MLP, max pool over the group."""

    def __init__(self, n_centres: int, radius_m: float, k: int, c_in: int, widths: list[int]):
        super().__init__()
        self.n_centres, self.radius_m, self.k = int(n_centres), float(radius_m), int(k)
        self.mlp = SharedMLP(c_in + 3, widths)

    def forward(self, xyz: torch.Tensor, feats: torch.Tensor):
        """xyz (B, N, 3), feats (B, N, F) -> centres (B, S, 3), features (B, S, F')."""
        centre_idx = farthest_point_sample(xyz, min(self.n_centres, xyz.shape[1]))
        centres = gather_points(xyz, centre_idx)
        group = ball_query(xyz, centres, radius_m=self.radius_m, k=self.k)  # (B, S, K)
        rel = (gather_points(xyz, group) - centres[:, :, None]) / self.radius_m
        grouped = torch.cat([rel, gather_points(feats, group)], dim=-1)  # (B, S, K, 3+F)
        return centres, self.mlp(grouped).amax(dim=2)  # (B, S, F')


class FeaturePropagation(nn.Module):
    """One FP level: 3-NN interpolation from the coarse level, skip link, shared MLP."""

    def __init__(self, c_coarse: int, c_skip: int, widths: list[int]):
        super().__init__()
        self.mlp = SharedMLP(c_coarse + c_skip, widths)

    def forward(self, xyz_fine, xyz_coarse, feats_fine, feats_coarse) -> torch.Tensor:
        """-> (B, N_fine, F') features of the fine level."""
        up = three_nn_interpolate(xyz_fine, xyz_coarse, feats_coarse)
        return self.mlp(torch.cat([up, feats_fine], dim=-1))


# ---------------------------------------------------------------- the network


@register("segmentation", "pointnet2")
class PointNet2Seg(nn.Module):
    """PointNet++ segmentation network over the points of range images (module docstring).

    ``auto_bf16 = False``: precision "auto" keeps it fp32 on a CPU, where bf16 autocast
    trained it slower (0.86x, ``python -m spl_al.bench training``): its time goes to
    point sampling, neighbour search and many small layers, not to large products.

    Args:
        n_classes: number of classes C.
        grid: the scan grid of the images (``spl_al.scenes.raycast.ScanGrid``, or
            anything with ``shape`` and ``directions()`` (rows, cols, 3)); it fixes
            each pixel's ray and so the image shape the model accepts.
        n_points: N, points sampled per cloud.
        centres: S_k, centres of each set-abstraction level (decreasing, S_1 <= N).
        radii_m: R_k, ball radius of each level in metres.
        neighbours: K, points per ball.
        width: channels of level 1; level k's MLP is (w 2^(k-1), w 2^(k-1), w 2^k),
            feature propagation mirrors it and the output features have d = width.
        coord_scale_m: metres per unit of the per-point input features when
            ``input_norm`` is False.
        input_norm: standardise the input features (x, y, z, r) per channel with a
            batch norm (no learned scale or shift); False feeds (x, y, z, r) /
            coord_scale_m.
        loss_at: where training scores the network (``training_outputs``): "points"
            (the N sampled points, as PointNet++ trains) or "pixels" (every valid
            pixel, through the interpolation evaluation uses).
    """

    task = "segmentation"
    input_kind = "range_m"
    needs_grid = True
    auto_bf16 = False

    def __init__(
        self,
        n_classes: int,
        *,
        grid=None,
        n_points: int = 1024,
        centres=(256, 64, 16),
        radii_m=(1.0, 3.0, 8.0),
        neighbours: int = 16,
        width: int = 16,
        coord_scale_m: float = 20.0,
        loss_at: str = "points",
        input_norm: bool = True,
    ):
        super().__init__()
        if grid is None:
            raise ValueError(
                "pointnet2 needs the scan grid of the images (grid=dataset.grid()) "
                "to turn range pixels into points."
            )
        centres, radii_m = [int(c) for c in centres], [float(r) for r in radii_m]
        if int(n_points) < 1 or not centres or len(radii_m) != len(centres):
            raise ValueError(
                f"pointnet2 needs n_points >= 1 and one radius per level, got n_points "
                f"{n_points}, centres {centres} and radii_m {radii_m}."
            )
        if any(c < 1 for c in centres) or any(
            a < b for a, b in zip([int(n_points), *centres], centres, strict=False)
        ):
            raise ValueError(
                f"centres must decrease from at most n_points = {n_points}, got {centres}."
            )
        if min(radii_m) <= 0 or int(neighbours) < 1 or int(width) < 1 or coord_scale_m <= 0:
            raise ValueError(
                "radii_m, neighbours, width and coord_scale_m must be positive, got "
                f"{radii_m}, {neighbours}, {width}, {coord_scale_m}."
            )
        if loss_at not in ("points", "pixels"):
            raise ValueError(f"loss_at must be 'points' or 'pixels', got {loss_at!r}.")
        self.loss_at = loss_at
        directions = np.asarray(grid.directions(), dtype=np.float32)
        if directions.ndim != 3 or directions.shape[-1] != 3:
            raise ValueError(f"grid.directions() must be (rows, cols, 3), got {directions.shape}.")
        self.register_buffer("directions", torch.from_numpy(directions.copy()), persistent=False)
        self.n_classes = int(n_classes)
        self.n_points = int(n_points)
        self.coord_scale_m = float(coord_scale_m)
        self.feature_dim = int(width)
        levels = len(centres)
        sa_out = [width * 2**k for k in range(1, levels + 1)]
        c_in = 4
        self.sa = nn.ModuleList()
        for k in range(levels):
            w = width * 2**k
            self.sa.append(SetAbstraction(centres[k], radii_m[k], neighbours, c_in, [w, w, 2 * w]))
            c_in = 2 * w
        # FP from the coarsest level down; skip channels: level k-1's output (4 at the points)
        skips = [4, *sa_out[:-1]]
        self.fp = nn.ModuleList()
        c_coarse = sa_out[-1]
        for k in range(levels - 1, -1, -1):
            w = width * 2**k  # level k's channels; d = width at the points
            self.fp.append(FeaturePropagation(c_coarse, skips[k], [2 * w, w] if k else [w, w]))
            c_coarse = w
        self.head = nn.Linear(width, self.n_classes)
        self.input_norm = nn.BatchNorm1d(4, affine=False) if input_norm else None
        self._sample_seed = 0
        self._generator: torch.Generator | None = None
        self.init_weights()

    def init_weights(self) -> None:
        """He-initialised shared MLPs (as their 1x1 convolutions would be), unit/zero
        batch norm, default head; the point sampler's seed is drawn from the (seeded)
        global RNG too."""
        for m in self.modules():
            if isinstance(m, SharedMLP):
                for linear in m.linears:
                    nn.init.kaiming_normal_(linear.weight, mode="fan_out", nonlinearity="relu")
                for norm in m.norms:
                    norm.reset_parameters()
        self.head.reset_parameters()
        if self.input_norm is not None:
            self.input_norm.reset_running_stats()
        self._draw_sample_seed()

    def _draw_sample_seed(self) -> None:
        """The point sampler's seed, from the global RNG (the caller has seeded it)."""
        self._sample_seed = int(torch.randint(0, 2**62, (1,)).item())
        self._generator = None

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        # weights from a model with the other input_norm setting were trained on other
        # inputs: refuse them with the fix, not a list of missing keys
        saved = f"{prefix}input_norm.running_mean" in state_dict
        if saved != (self.input_norm is not None):
            raise ValueError(
                f"these PointNet++ weights were saved {'with' if saved else 'without'} "
                f"input normalisation; build the model with input_norm: {str(saved).lower()} "
                "to load them."
            )
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    def seed_sampler(self, seed: int) -> None:
        """Draw the point sampler's seed from ``seed``, weights untouched: a fine-tuning
        (weights loaded, not re-initialised) samples its points from the training seed,
        not from whatever state the global RNG had when the model was built."""
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(int(seed))
            self._draw_sample_seed()

    def _sampler(self) -> torch.Generator | None:
        if not self.training:
            return None
        if self._generator is None:
            self._generator = torch.Generator().manual_seed(self._sample_seed)
        return self._generator

    def point_features(self, xyz_m: torch.Tensor, range_m: torch.Tensor) -> torch.Tensor:
        """Per-point input features (B, N, 4): (x, y, z, range) in metres, each channel
        standardised by ``input_norm`` (batch statistics in training, running ones in
        evaluation); without it (x, y, z, range) / coord_scale_m."""
        f = torch.cat([xyz_m, range_m[..., None]], dim=-1)
        if self.input_norm is None:
            return f / self.coord_scale_m
        return self.input_norm(f.reshape(-1, 4)).reshape(f.shape)

    def point_forward(self, xyz_m: torch.Tensor, feats: torch.Tensor) -> torch.Tensor:
        """The point network: xyz (B, N, 3) metres, feats (B, N, 4) -> features (B, N, d).

        Equivariant to permutations of the N points (up to ties in distances).
        """
        xyzs, fs = [xyz_m], [feats]
        for sa in self.sa:
            centres, f = sa(xyzs[-1], fs[-1])
            xyzs.append(centres)
            fs.append(f)
        f = fs[-1]
        for i, fp in enumerate(self.fp):
            k = len(self.sa) - 1 - i  # fine level
            f = fp(xyzs[k], xyzs[k + 1], fs[k], f)
        return f

    def _sampled_points(self, x: torch.Tensor):
        """x (B, 2, H, W) -> pixel xyz (B, P, 3), validity (B, P), sampled pixels (B, N)
        and the point network's features at them (B, N, d)."""
        b, _, h, w = x.shape
        if (h, w) != tuple(self.directions.shape[:2]):
            raise ValueError(
                f"pointnet2 was built for {tuple(self.directions.shape[:2])} scans, "
                f"got images of {(h, w)}."
            )
        x = x.float().contiguous()
        range_m = x[:, 0].reshape(b, -1)
        valid = (x[:, 1] > 0).reshape(b, -1)
        xyz = range_m[..., None] * self.directions.reshape(1, -1, 3)  # (B, P, 3)
        idx = sample_pixels(valid, self.n_points, self._sampler())
        pts = gather_points(xyz, idx)
        pts_range_m = torch.gather(range_m, 1, idx)
        feats = self.point_forward(pts, self.point_features(pts, pts_range_m))
        return xyz, valid, idx, pts, feats

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """x (B, 2, H, W) range (m) and validity -> logits (B, C, H, W), features (B, d, H, W)."""
        b, _, h, w = x.shape
        xyz, valid, _, pts, feats = self._sampled_points(x)
        pixel_feats = three_nn_interpolate(xyz, pts, feats)  # (B, P, d)
        logits = self.head(pixel_feats)
        keep = valid[..., None].to(logits.dtype)
        logits = (logits * keep).transpose(1, 2).reshape(b, -1, h, w)
        features = (pixel_feats * keep).transpose(1, 2).reshape(b, -1, h, w)
        return logits, features

    def training_outputs(
        self, x: torch.Tensor, target: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """What a training step scores: x (B, 2, H, W), target (B, H, W) ->
        (logits, target) of the same units.

        ``loss_at`` "points" (PointNet++'s own training): the N sampled points, logits
        (B, C, N) and their pixels' targets (B, N); the interpolation back to every
        pixel, about a third of a step on the CPU, is left out. "pixels": every pixel,
        ``forward``'s logits (B, C, H, W) and ``target`` as given.
        """
        if self.loss_at == "pixels":
            return self(x)[0], target
        _, _, idx, _, feats = self._sampled_points(x)
        logits = self.head(feats).transpose(1, 2)  # (B, C, N)
        return logits, torch.gather(target.reshape(target.shape[0], -1), 1, idx)
