# spl-al: condition-aware active learning for single-photon LiDAR.
# Rules live in workflow/rules/, numerics in the spl_al library.
from snakemake.utils import min_version, validate

min_version("9.0")


configfile: "config/config.yaml"


validate(config, "config/schema.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/photon.smk"


rule all:
    default_target: True
    input:
        photon_pictures(),
