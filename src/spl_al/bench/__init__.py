"""Benchmarks that print a table: ``python -m spl_al.bench NAME [options]``.

Each benchmark is a module ``spl_al.bench.NAME`` with a ``main(argv)`` function.
"""
