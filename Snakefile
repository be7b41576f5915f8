# spl-al: condition-aware active learning for single-photon LiDAR.
# Rules live in workflow/rules/ (data, al, report), numerics in the spl_al library.
import copy
import sys
from pathlib import Path

from snakemake.utils import min_version

# The Snakefile reads the library of its own checkout (src/) before any installed copy,
# so that `snakemake -n` works in a checkout that is not installed (jobs need the install:
# scripts/install.sh).
_SRC = Path(workflow.basedir) / "src"
if (_SRC / "spl_al").is_dir():
    sys.path.insert(0, str(_SRC))

from spl_al.config import check_config, drop_removed, select_datasets
from spl_al.experiment.shared_embedding import share_embeddings

min_version("9.0")

# What --configfile and --config gave, before the defaults are merged under it.
OVERRIDES = copy.deepcopy(config)


# config/config.yaml holds every default; --configfile FILE and --config KEY=VALUE
# are merged on top of it by Snakemake (nested keys one by one, lists replaced whole).
# A key set to null in an override is removed (e.g. `datasets: {synth_cls: null}`).
# `only_datasets: [NAME, ...]` runs exactly those datasets (docs/configuration.md).
# Found beside this file, so a run from another folder (snakemake -s PATH/Snakefile,
# --directory) reads the same defaults.
configfile: Path(workflow.basedir) / "config" / "config.yaml"


drop_removed(config)
try:
    INHERITED = select_datasets(config, OVERRIDES)
    check_config(config, Path(workflow.basedir) / "config" / "schema.yaml")
    # dataset -> the dataset whose embedding encoders and runs it reads
    SHARED_EMBEDDING = share_embeddings(config)
except ValueError as err:
    sys.exit(f"Error: {err}")


include: "workflow/rules/common.smk"
include: "workflow/rules/functions/photon.smk"
include: "workflow/rules/functions/captures.smk"
include: "workflow/rules/functions/data.smk"
include: "workflow/rules/functions/al.smk"
include: "workflow/rules/functions/human.smk"
include: "workflow/rules/functions/report.smk"
include: "workflow/rules/functions/embedding.smk"
include: "workflow/rules/functions/robustness.smk"
include: "workflow/rules/functions/deploy.smk"
include: "workflow/rules/functions/warm.smk"
include: "workflow/rules/photon.smk"
include: "workflow/rules/captures.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/al.smk"
include: "workflow/rules/human.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/embedding.smk"
include: "workflow/rules/robustness.smk"
include: "workflow/rules/deploy.smk"
include: "workflow/rules/warm.smk"


rule all:
    default_target: True
    input:
        f"{RESULTS}/config.yaml",
        photon_pictures(),
        [dataset_outputs(d) for d in DATASETS],
        [embedding_outputs(d) for d in DATASETS],
