#!/usr/bin/env bash
# "Submit" a Snakemake job script: run it detached, print its process id as job id.
set -euo pipefail
jobscript="${!#}"
nohup bash "$jobscript" > "$jobscript.out" 2>&1 < /dev/null &
echo "$!"
