#!/usr/bin/env bash
# Installs spl-al and its dev tools into the current Python.
# A torch that is already installed (for example a CUDA build) is kept; otherwise
# the CPU build 2.13.0 is installed, which on these machines comes from a local wheel
# instead of pulling several GB of CUDA packages.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if ! "$PY" -c "import torch" >/dev/null 2>&1; then
  "$PY" -m pip install --quiet torch==2.13.0
fi
"$PY" -m pip install --quiet -e ".[dev]"
