"""The experiment protocol: which runs a config asks for, and each step of a round.

- ``plan``: methods (named strategy entries), generated sensitivity sweeps, and the
  (method, seed, rounds) runs each dataset's experiments need. Light: no torch.
- ``data_steps``, ``round_steps``, ``embedding_steps``, ``report_steps``,
  ``deploy_steps``, ``human``, ``robustness``: the step modules, whose functions the
  workflow's scripts call, one per rule (``embedding_steps``: the embedding
  framework's encoder and runs). None imports another (tests/test_imports.py): what
  two share lives in a module of its own.
- Shared by the steps: ``round0`` (round 0's labeled set chosen and written; its
  ``initial_set`` is the simulated oracle's rule), ``fits`` (a round's model trained
  and evaluated), ``pool_scores`` (the unlabeled pool scored), ``encoders`` (which
  encoder a run seed reads), ``outputs`` (what `all` asks of a dataset in a
  framework).
- ``step_args``: the small records a step takes (``RoundId``,
  ``ModelFiles``, ``RoundStart``, ``ProbeRuns``; ``Compute`` is ``spl_al.training``'s), importable
  without numpy or torch.

How a job runs (the warm server, its client and the job log) is ``spl_al.warm``.
"""
