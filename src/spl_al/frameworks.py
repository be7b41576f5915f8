"""How a round learns and what a strategy's features are, each declared once.

Two small registries, read by the plan, the overview, the report, the docs pages, the
benches and the workflow, so none of them names a framework or a feature space by a
string of its own:

- a **framework kind** (``FrameworkKind``): how a round's model learns from the
  labeled groups. ``supervised`` trains the configured network on them (the paper's
  protocol; a dataset's ``experiments``); ``embedding`` fits a linear classifier on
  a frozen self-supervised encoder's embeddings (a dataset's
  ``embedding.experiments``; ``spl_al.linear_probe``). The kind holds where its
  experiments sit in a dataset's config entry, its results subfolder, the note its
  tables and figures carry, the precision its measurements are made at, and the
  feature space every method of it selects on.
- a **feature space** (``FeatureSpace``): where a feature-only strategy's features
  come from in the supervised framework (a method's ``features`` setting): the
  trained model's penultimate features (``model``) or the dataset's self-supervised
  embedding (``embedding``).

Add one by ``register_framework`` / ``register_feature_space``; the contract test
(``tests/test_frameworks.py``) registers a third framework and follows it to the
plan, the outputs and the tables.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FeatureSpace:
    """Where a strategy's features come from: ``words`` says it in a claim
    ("selecting on {words}"); ``needs_encoder``: the dataset's self-supervised encoder
    must be trained for it (its embeddings feed the rounds)."""

    name: str
    words: str
    needs_encoder: bool = False


@dataclass(frozen=True)
class FrameworkKind:
    """One way a round learns (module docstring).

    ``experiments_at``: the keys, from a dataset's config entry, of the mapping that
    holds its experiments; ``block``: the entry's key that switches it on and holds
    its settings (None: always on, the entry itself); ``subfolder``: under
    ``results/{dataset}/`` ("" for the dataset's folder itself); ``model``: what a
    round fits, in a sentence (empty: the configured network, said nowhere), from which
    ``note`` and ``claims_words`` are made; ``short``: the same in a figure title's
    words; ``measured_at``: the precision every measurement is made at whatever the
    run's (None: the run's own); ``features``: the feature space every method selects
    on (None: each method's own ``features``); ``unit``: what its runs share a draw of
    (``seed``, or ``encoder`` where seeds share an encoder: its tables then say how
    many encoders and which are doubtful). The statistics find the grouping in the
    records themselves (``report.stats``)."""

    name: str
    experiments_at: tuple[str, ...]
    block: str | None = None
    subfolder: str = ""
    model: str = ""
    short: str = ""
    measured_at: str | None = None
    features: str | None = None
    unit: str = "seed"

    @property
    def key(self) -> str:
        """The dotted config key of its experiments under a dataset ("experiments")."""
        return ".".join(self.experiments_at)

    @property
    def note(self) -> str:
        """What its tables, figures and summaries say of it ("" for the default)."""
        if not self.model:
            return ""
        precision = self.measured_at or "at the run's precision"
        return f"{self.name} framework: each round {self.model}, {precision}"

    def claims_words(self, precision: str) -> str:
        """How a claims table's title says where its models came from."""
        if not self.model:
            return f" (models trained in {precision})" if precision else ""
        return f" in the {self.name} framework ({self.model}, {precision or self.measured_at})"

    def experiments(self, entry: dict) -> dict:
        """A dataset entry's experiments in this framework, as configured ({} if none)."""
        node = entry
        for part in self.experiments_at:
            node = (node or {}).get(part)
        return dict(node or {})

    def settings(self, entry: dict) -> dict:
        """The entry's block of this framework ({} when it has none; the entry itself for
        a framework without a block)."""
        return dict(entry) if self.block is None else dict(entry.get(self.block) or {})

    def enabled(self, entry: dict) -> bool:
        """Whether a dataset entry switches this framework on (has its block)."""
        return self.block is None or bool(entry.get(self.block))

    def folder(self, results, dataset: str) -> str:
        """``results/{dataset}[/{subfolder}]``, where its tables and figures go."""
        base = f"{results}/{dataset}"
        return f"{base}/{self.subfolder}" if self.subfolder else base


_SPACES: dict[str, FeatureSpace] = {}
_FRAMEWORKS: dict[str, FrameworkKind] = {}


def _add(registry: dict, what: str, item):
    if item.name in registry:
        raise ValueError(f"{what} {item.name!r} is already registered.")
    registry[item.name] = item
    return item


def register_feature_space(space: FeatureSpace) -> FeatureSpace:
    """Add ``space`` to the registry (its name must be new); returns it."""
    return _add(_SPACES, "feature space", space)


def register_framework(kind: FrameworkKind) -> FrameworkKind:
    """Add ``kind`` to the registry (its name must be new); returns it."""
    return _add(_FRAMEWORKS, "framework", kind)


def unregister_framework(name: str) -> None:
    """Remove a framework registered by ``register_framework`` (a test's own kind)."""
    if name in (SUPERVISED.name, EMBEDDING.name):
        raise ValueError(f"framework {name!r} is built in and stays registered.")
    del _FRAMEWORKS[name]


def feature_space_names() -> tuple[str, ...]:
    """Registered feature spaces, the default (``model``) first."""
    return tuple(_SPACES)


def framework_names() -> tuple[str, ...]:
    """Registered frameworks, the default (``supervised``) first."""
    return tuple(_FRAMEWORKS)


def get_feature_space(name: str) -> FeatureSpace:
    """The registered feature space ``name``; a ValueError naming the known ones else."""
    if name not in _SPACES:
        raise ValueError(f"features must be one of {list(_SPACES)}, got {name!r}.")
    return _SPACES[name]


def get_framework(name) -> FrameworkKind:
    """The registered framework ``name`` (a kind passes through); a ValueError naming
    the known ones else."""
    if isinstance(name, FrameworkKind):
        return name
    if name not in _FRAMEWORKS:
        raise ValueError(f"framework must be one of {list(_FRAMEWORKS)}, got {name!r}.")
    return _FRAMEWORKS[name]


MODEL_FEATURES = register_feature_space(
    FeatureSpace("model", "the trained CNN's penultimate features")
)
EMBEDDING_FEATURES = register_feature_space(
    FeatureSpace("embedding", "the frozen self-supervised embedding", needs_encoder=True)
)

SUPERVISED = register_framework(FrameworkKind("supervised", ("experiments",)))
EMBEDDING = register_framework(
    FrameworkKind(
        "embedding",
        ("embedding", "experiments"),
        block="embedding",
        subfolder="embedding",
        model="a linear classifier on a frozen self-supervised encoder's embeddings",
        short="linear classifier, frozen encoder",
        measured_at="fp32",
        features=EMBEDDING_FEATURES.name,
        unit="encoder",
    )
)
DEFAULT = SUPERVISED
