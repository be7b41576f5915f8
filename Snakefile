# spl-al: condition-aware active learning for single-photon LiDAR.
# Rules live in workflow/rules/ (data, al, report), numerics in the spl_al library.
import sys

from snakemake.utils import min_version

from spl_al.config import check_config

min_version("9.0")


# --configfile FILE replaces the embedded default instead of being merged into it,
# so config/ci.yaml and config/paper.yaml are complete on their own.
if not workflow.overwrite_configfiles:

    configfile: "config/config.yaml"


try:
    check_config(config, "config/schema.yaml")
except ValueError as err:
    sys.exit(f"Error: {err}")


include: "workflow/rules/common.smk"
include: "workflow/rules/photon.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/al.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/robustness.smk"


rule all:
    default_target: True
    input:
        photon_pictures(),
        [dataset_outputs(d) for d in DATASETS],
