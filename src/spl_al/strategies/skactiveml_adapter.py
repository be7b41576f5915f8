"""scikit-activeml's pool query strategies as spl-al strategies, through one adapter.

scikit-activeml (>= 1.0, the optional extra ``pip install spl-al[baselines]``) ships
the low-budget strategies of the literature as pool query strategies over feature
vectors: TypiClust (Hacohen et al. 2022), ProbCover (Yehuda et al. 2022) and
MaxHerding (Bae et al. 2024) among them. ``SkactivemlStrategy`` calls one of them on
what ``StrategyInputs`` holds and nothing else:

- ``X`` is the labeled groups' observed-image features followed by the unlabeled
  groups' (``labeled_features``, then ``features``);
- ``y`` says only which rows are labeled: the placeholder class 0 for every labeled
  row and scikit-activeml's missing label (NaN) for every unlabeled one. No label is
  known to the adapter, so none can reach the strategy (a test permutes the labeled
  rows' real classes in a direct call and gets the same picks);
- ``random_state`` is an integer drawn from the query's ``rng``, so a seed gives the
  same picks and every random choice of the strategy comes from the round's seed.

The picks are scikit-activeml's own (a test compares them with a direct call). Only
where its batch repeats a sample (TypiClust 1.0.1 on identical features, e.g. an
untrained model: k-means finds fewer distinct clusters than the batch, and its
fallback, a uniform draw, may draw a sample twice) does the adapter keep the first
occurrences and draw the rest of the batch uniformly from the unpicked unlabeled
groups with the round's ``rng``, what TypiClust's fallback means to do; where every
cluster holds a labeled sample, where TypiClust 1.0.1 fails, the whole batch is drawn so.

Only strategies that need features and the labeled/unlabeled split are accepted: a
class whose ``query`` needs a classifier to fit on labels (``clf``, ``ensemble``,
``discriminator``, ...) or a stream strategy is refused when the config is read, in
one sentence naming the class and what it needs (``skactiveml_class``).

Registered names: ``skactiveml`` (any accepted class: ``cls="TypiClust"`` plus its
constructor parameters) and ``maxherding`` (scikit-activeml's MaxHerding with its
paper's kernel). TypiClust and ProbCover are spl-al's own (``spl_al.strategies.typiclust``,
``spl_al.strategies.probcover``): scikit-activeml's cannot be set to run as their
papers do.
scikit-activeml (and with it scikit-learn) is imported only when such a strategy is
built, so ``import spl_al.strategies`` stays numpy-only.
"""

from __future__ import annotations

import inspect

import numpy as np

from spl_al.strategies.base import Strategy, StrategyContractError, register
from spl_al.strategies.inputs import StrategyInputs

INSTALL_HINT = "pip install 'spl-al[baselines]'"
# the arguments of a pool strategy's query() the adapter can give
QUERY_ARGS = frozenset({"self", "X", "y", "candidates", "batch_size", "return_utilities", "update"})
# constructor arguments the adapter sets itself
ADAPTER_ARGS = frozenset({"missing_label", "random_state"})
EXAMPLES = "TypiClust, ProbCover or MaxHerding"


def skactiveml_class(name: str) -> type:
    """The scikit-activeml pool strategy class ``name``, or a one-sentence ValueError
    saying why it cannot run here (not installed, unknown, a stream strategy, or a
    strategy that needs more than features and which samples are labeled)."""
    try:
        import skactiveml.pool as pool
        from skactiveml.base import SingleAnnotatorPoolQueryStrategy
    except ImportError:
        raise ValueError(
            f"strategy {name!r} comes from scikit-activeml, which is not installed: "
            f"{INSTALL_HINT} (or bash scripts/install.sh)."
        ) from None
    cls = getattr(pool, str(name), None)
    if not (inspect.isclass(cls) and issubclass(cls, SingleAnnotatorPoolQueryStrategy)):
        import skactiveml.stream as stream

        if hasattr(stream, str(name)):
            raise ValueError(
                f"scikit-activeml's {name} is a stream strategy (it decides on one sample "
                f"at a time as they arrive), but a round queries a pool; use a pool "
                f"strategy that needs features only, such as {EXAMPLES}."
            )
        raise ValueError(
            f"scikit-activeml has no single-annotator pool strategy {name!r}; use one that "
            f"needs features only, such as {EXAMPLES}."
        )
    query = inspect.signature(cls.query).parameters
    needed = [
        p
        for p, v in query.items()
        if p not in QUERY_ARGS
        and v.default is inspect.Parameter.empty
        and v.kind not in (v.VAR_POSITIONAL, v.VAR_KEYWORD)
    ]
    if needed:
        raise ValueError(
            f"scikit-activeml's {name} needs {', '.join(needed)} besides the features "
            f"(a model it fits or queries on the labels), but a spl-al strategy gets "
            f"features and which samples are labeled only, never a label; use one such "
            f"as {EXAMPLES}."
        )
    return cls


def adapter_data(inputs: StrategyInputs) -> tuple[np.ndarray, np.ndarray]:
    """``X`` (labeled rows first, then unlabeled) and the label-free ``y`` a
    scikit-activeml strategy is called with: 0 for labeled rows, NaN for unlabeled."""
    n_lab = len(inputs.labeled_idx)
    feats = np.asarray(inputs.features)
    lab = np.asarray(inputs.labeled_features).reshape(n_lab, feats.shape[1])
    x = np.concatenate([lab, feats]).astype(np.float64)
    y = np.full(len(x), np.nan)
    y[:n_lab] = 0.0
    return x, y


def query_seed(rng: np.random.Generator) -> int:
    """The integer ``random_state`` a query passes to scikit-activeml, drawn from ``rng``."""
    return int(rng.integers(0, 2**31 - 1))


@register
class SkactivemlStrategy(Strategy):
    """Any accepted scikit-activeml pool strategy: ``cls`` (its class name) and its
    constructor parameters, called on the observed images' features."""

    name = "skactiveml"
    needs = frozenset({"features", "labeled_features"})

    def __init__(self, cls: str, **params):
        self.cls = str(cls)
        self.query_class = skactiveml_class(self.cls)
        accepted = set(inspect.signature(self.query_class.__init__).parameters) - {"self"}
        unknown = sorted(set(params) - (accepted - ADAPTER_ARGS))
        if unknown:
            set_here = sorted(set(unknown) & ADAPTER_ARGS)
            why = (
                f"{set_here} are set by the adapter (the seed from the round's rng)"
                if set_here
                else f"{self.cls} takes {sorted(accepted - ADAPTER_ARGS)}"
            )
            raise TypeError(f"unexpected parameters {unknown} for {self.cls}: {why}")
        self.query_params = dict(params)

    def params(self) -> dict:
        """The class name and its parameters."""
        return {"cls": self.cls, **self.query_params}

    def build(self, random_state: int):
        """The scikit-activeml strategy object for one query."""
        return self.query_class(**self.query_params, random_state=random_state)

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        x, y = adapter_data(inputs)
        n_lab = len(inputs.labeled_idx)
        try:
            picked = np.asarray(self.build(query_seed(rng)).query(x, y, batch_size=k))
        except UnboundLocalError:
            if self.cls != "TypiClust":
                raise
            # TypiClust 1.0.1 fails when a labeled sample covers every cluster (all
            # features alike); its rule for that case is a uniform draw: no picks here,
            # all drawn below
            picked = np.zeros(0, dtype=np.int64)
        rows = list(dict.fromkeys(_check_rows(self.name, picked, y, k, n_lab).tolist()))
        if len(rows) < k:  # a repeated sample: the rest uniformly from the unpicked rows
            rest = np.setdiff1d(np.arange(n_lab, len(x)), rows)
            rows += rng.choice(rest, size=k - len(rows), replace=False).tolist()
        return np.asarray(rows, dtype=np.int64) - n_lab


def _check_rows(name: str, picked: np.ndarray, y: np.ndarray, batch: int, n_lab: int):
    """scikit-activeml's picks as rows of ``X``, each an unlabeled one and ``batch`` of
    them (repeats allowed, or none after TypiClust's failure: the caller completes the
    batch), else a
    ``StrategyContractError`` naming the strategy and what it returned."""
    rows = picked.astype(np.int64).ravel()
    outside = (rows < 0).any() or (rows >= len(y)).any()
    if len(rows) not in (0, batch) or outside or (y[rows] == 0).any():
        raise StrategyContractError(
            f"scikit-activeml strategy {name!r} returned rows {rows.tolist()[:12]} of X for a "
            f"batch of {batch}, not rows of unlabeled groups ({n_lab}..{len(y) - 1}, "
            "its unlabeled rows)."
        )
    return rows


class _Named(SkactivemlStrategy):
    """A scikit-activeml class under a short registered name."""

    CLS = ""

    def __init__(self, **params):
        super().__init__(self.CLS, **params)

    def params(self) -> dict:
        """The class's parameters."""
        return dict(self.query_params)


@register
class MaxHerdingStrategy(_Named):
    """MaxHerding (Bae, Noh and Sutherland, ECCV 2024) with its paper's Gaussian kernel.

    "Generalized Coverage for More Robust Low-Budget Active Learning": greedy
    maximisation of the generalised coverage mean_j max(k(x_j, s) - max_{l in L}
    k(x_j, l), 0) over the pool, with the kernel of its reference code
    (github.com/BorealisAI/uherding)::

        k(x, y) = exp(-(||x - y|| / h)^2)   on L2-normalised features, h = 1

    scikit-activeml's ``MaxHerding`` runs this greedy exactly, given that kernel:
    ``normalize_samples=True`` and ``metric_dict={"gamma": 1 / h^2}``. Its default
    gamma = 1 / d (d = 128: every pair of unit vectors within 0.97..1.0) hardly told
    near from far; h = 1 spans 0.02..1.

    Args:
        bandwidth: h, in units of the unit-length features' distances (0..2).
    """

    name = "maxherding"
    CLS = "MaxHerding"

    def __init__(self, bandwidth: float = 1.0):
        if isinstance(bandwidth, bool) or not isinstance(bandwidth, int | float) or bandwidth <= 0:
            raise ValueError(f"maxherding: bandwidth must be a number > 0, got {bandwidth!r}.")
        self.bandwidth = float(bandwidth)
        super().__init__(
            normalize_samples=True, metric="rbf", metric_dict={"gamma": 1.0 / self.bandwidth**2}
        )

    def params(self) -> dict:
        """The kernel bandwidth h."""
        return {"bandwidth": self.bandwidth}

    def kernel(self, a, b) -> np.ndarray:
        """k(a_i, b_j) of the (n, d) and (m, d) features as the selection computes it."""
        from sklearn.metrics import pairwise_kernels
        from sklearn.preprocessing import normalize

        return pairwise_kernels(
            normalize(np.asarray(a, dtype=np.float64)),
            normalize(np.asarray(b, dtype=np.float64)),
            metric="rbf",
            gamma=1.0 / self.bandwidth**2,
        )

    def _select(self, inputs: StrategyInputs, k: int, rng: np.random.Generator) -> np.ndarray:
        picked = super()._select(inputs, k, rng)
        self.decision = {"bandwidth": self.bandwidth}
        return picked
