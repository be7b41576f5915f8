"""Generators of the repository's documentation pages.

``spl_al.docs.configuration`` writes docs/configuration.md from config/schema.yaml and
config/config.yaml; ``spl_al.docs.results_blocks`` writes the results block of
docs/results.md (and of the other run pages) from a results folder;
``spl_al.docs.answer`` writes the README's answer table from the embedding run's and
the decisive runs' claims. Each is plain functions with a thin ``python -m`` entry
point; none imports Snakemake.
"""
