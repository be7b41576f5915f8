"""spl-al: condition-aware active learning for single-photon LiDAR (SPL) perception.

``spl_al.query(method, predict, depth_m, valid, labeled=..., budget=...)`` asks DUIS
(or any registered strategy) which frames to label next, with your own model's
``predict``; ``spl_al.make_variants`` makes a pool's SIV variants once for every
round's query (``spl_al.acquire``; loaded on first use, so ``import spl_al`` stays
cheap).

Areas, top layer first (docs/design.md is the map; a module imports only its own
package and the layers below it):

- tools: ``spl_al.bench`` (benchmarks that print tables: ``python -m spl_al.bench
  NAME``), ``spl_al.docs`` (the generated docs pages and README blocks), ``spl-al
  estimate|reconstruct|export|predict|query`` (``__main__``; ``spl_al.query_frames``:
  a trained model picks a folder's next labeling batch).
- workflow steps: ``spl_al.experiment`` (the plan of a config, one function per rule,
  what `all` asks for), ``spl_al.warm`` (how a job runs: the warm job server).
- outputs: ``spl_al.report`` (tables, curves, statistics, claims), ``spl_al.deploy``
  (model cards, ONNX export, prediction), ``spl_al.labeling`` (labeling batches, Label
  Studio).
- round 0: ``spl_al.cold_start`` (random, stratified, or a first batch without labels).
- active learning: ``spl_al.pool`` (labeled sets, the simulated oracle),
  ``spl_al.round_query`` (a round's query), ``spl_al.acquire`` (``spl_al.query``: any
  strategy with a model of your own), ``spl_al.scoring`` (the forward passes a strategy
  needs), ``spl_al.linear_probe`` (the embedding framework's classifier),
  ``spl_al.dense_probe`` (its per-pixel counterpart for segmentation).
- learning: ``spl_al.strategies`` (every acquisition strategy behind one registry),
  ``spl_al.training`` (training, evaluation, precision, the self-supervised encoders).
- ``spl_al.models`` (CNN, ResNet-18, U-Net, PointNet++), ``spl_al.data`` (datasets,
  their sources and files, SIV variants), ``spl_al.photon`` (the SPL measurement
  model, photon simulation, reconstruction, captures), ``spl_al.scenes`` (procedural
  geometry).
- kit: ``spl_al.config``, ``spl_al.frameworks`` (framework kinds and feature spaces,
  declared once), ``spl_al.plotting``.
- ground: ``spl_al.atomic`` (atomic writes), ``spl_al.label_codes``, ``spl_al.layout``
  (where a run's files lie), ``spl_al.seeding`` (every random stream).
"""

__version__ = "0.1.0"
__all__ = ["__version__", "make_variants", "query"]


def __getattr__(name: str):
    """``spl_al.query`` and ``spl_al.make_variants`` (``spl_al.acquire``), imported when
    first asked for."""
    if name in ("query", "make_variants"):
        # numpy, the strategies and the photon engine on first use: `import spl_al` stays cheap
        from spl_al import acquire

        return getattr(acquire, name)
    raise AttributeError(f"module 'spl_al' has no attribute {name!r}")
