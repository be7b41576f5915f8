"""Use a trained model outside the pipeline: model cards, ONNX export, prediction.

- ``card``: the model card (JSON + Markdown) beside a ``model.pt`` or ``.onnx``: what
  the model takes, what it was trained on and how well it does per MSPPP level.
- ``graph``: ``DeployGraph``, the model behind its input preprocessing (raw depth in
  metres in, logits and probabilities out): what an exported ONNX file holds.
- ``bundle``: ``open_model(path)``, a ``.pt`` or ``.onnx`` with its card, ready to run
  in torch or onnxruntime.
- ``export``: ``export_onnx(model.pt, OUT.onnx)``, checked against torch with
  onnxruntime on the dataset's test split.
- ``predict``: classify or segment release-layout frames and raw captures.

The command line is ``python -m spl_al export|predict`` (``spl_al.__main__``).
"""
