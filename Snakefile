# spl-al: condition-aware active learning for single-photon LiDAR.
# Rules live in workflow/rules/, numerics in the spl_al library.
import sys

from snakemake.utils import min_version

from spl_al.config import check_config

min_version("9.0")


configfile: "config/config.yaml"


try:
    check_config(config, "config/schema.yaml")
except ValueError as err:
    sys.exit(f"Error: {err}")


include: "workflow/rules/common.smk"
include: "workflow/rules/photon.smk"


rule all:
    default_target: True
    input:
        photon_pictures(),
