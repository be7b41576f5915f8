"""The experiment protocol: which runs a config asks for, and each step of a round.

- ``plan``: methods (named strategy entries), generated sensitivity sweeps, and the
  (method, seed, rounds) runs each dataset's experiments need. Light: no torch.
- ``steps``: the functions the workflow's scripts call, one per rule.
"""
