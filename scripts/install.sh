#!/usr/bin/env bash
# Installs spl-al, its dev tools and the optional scikit-activeml baselines
# (spl-al[baselines]) into the current Python ($PYTHON, default python3).
#
# torch, which is the only heavy dependency, is handled first:
# - a torch that is already installed (for example a CUDA build) is kept, when it is
#   2.5 or newer (older: one sentence, and nothing is installed);
# - on a machine with an NVIDIA driver (nvidia-smi works), torch==2.13.0 comes from
#   the normal package index, which on Linux x86_64 is the CUDA build;
# - otherwise (a CPU-only laptop) the CPU build torch==2.13.0 comes from PyTorch's
#   CPU index (about 200 MB instead of several GB of CUDA libraries); when that index
#   cannot be reached and pip finds no copy in its configured mirrors, the same pin
#   is installed from the normal package index (on Linux x86_64 that is the CUDA
#   build, several GB, which also runs on CPU).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
TORCH=torch==2.13.0
CPU_INDEX=https://download.pytorch.org/whl/cpu

# (versions from the package metadata: importing torch takes seconds)
if have=$("$PY" -c "from importlib.metadata import version; print(version('torch'))" 2>/dev/null); then
  # pyproject.toml asks for torch >= 2.5: an older one would make pip fetch a new build
  if ! "$PY" -c "import sys; v = tuple(int(x) for x in sys.argv[1].split('+')[0].split('.')[:2]); sys.exit(v < (2, 5))" "$have"; then
    echo "install.sh: the installed torch $have is older than 2.5, the oldest spl-al runs on; upgrade it (for a CUDA build, from your CUDA's PyTorch index) or uninstall it and run this again" >&2
    exit 1
  fi
  echo "install.sh: keeping the installed torch $have"
elif command -v nvidia-smi >/dev/null 2>&1 && nvidia-smi >/dev/null 2>&1; then
  echo "install.sh: NVIDIA GPU found, installing $TORCH from the package index (CUDA build)"
  "$PY" -m pip install --quiet "$TORCH"
elif "$PY" -m pip install --quiet --retries 1 --timeout 15 --index-url "$CPU_INDEX" "$TORCH"; then
  # pip also looks in the find-links / extra indexes of its own config (a local mirror)
  echo "install.sh: installed $TORCH for CPU (from $CPU_INDEX or pip's configured mirror)"
else
  echo "install.sh: $CPU_INDEX unreachable, installing $TORCH from the package index instead"
  "$PY" -m pip install --quiet "$TORCH"
fi
# the dev tools and the scikit-activeml baselines (typiclust, probcover, maxherding);
# with setuptools >= 68 already here (pyproject.toml's build requirement), the editable
# build uses it instead of installing it into a fresh build environment (~4 s)
isolation=()
if "$PY" -c "from importlib.metadata import version as v; assert int(v('setuptools').split('.')[0]) >= 68" 2>/dev/null; then
  isolation=(--no-build-isolation)
fi
"$PY" -m pip install --quiet "${isolation[@]}" -e ".[dev,baselines]"
"$PY" -c "import torch; print(f'install.sh: torch {torch.__version__}, CUDA available: {torch.cuda.is_available()}')"
