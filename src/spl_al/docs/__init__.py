"""Generators of the repository's documentation pages.

``spl_al.docs.configuration`` writes docs/configuration.md from config/schema.yaml and
config/config.yaml; ``spl_al.docs.results_blocks`` writes docs/results.md and the README's
results block from a results folder. Both are plain functions with thin ``python -m``
entry points; neither imports Snakemake.
"""
