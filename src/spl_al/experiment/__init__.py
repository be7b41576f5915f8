"""The experiment protocol: which runs a config asks for, and each step of a round.

- ``plan``: methods (named strategy entries), generated sensitivity sweeps, and the
  (method, seed, rounds) runs each dataset's experiments need. Light: no torch.
- ``data_steps``, ``round_steps``, ``report_steps``, ``deploy_steps``, ``human``: the
  functions the workflow's scripts call, one per rule.
- ``embedding_steps``: the embedding framework's encoder and runs.
- ``step_args``: the small records a step takes (``RoundId``,
  ``ModelFiles``, ``RoundStart``; ``Compute`` is ``spl_al.training``'s), importable
  without numpy or torch.

How a job runs (the warm server, its client and the job log) is ``spl_al.warm``.
"""
