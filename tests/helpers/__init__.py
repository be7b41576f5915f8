"""What the tests share and no test is: synthetic data, simulated captures, trained
models and the Snakemake command line. Import as ``from helpers.NAME import ...``
(pytest puts tests/ on the path, as it holds conftest.py)."""
