# Input functions of workflow/rules/captures.smk: a `source: captures` dataset's
# files, read once while the workflow is parsed so a bad capture stops the run here.
from spl_al.data.raw_captures import (
    CaptureOptions,
    capture_files,
    check_timing,
    not_read,
    shard_count,
    shard_of,
)

try:
    CAPTURE_OPTIONS = {
        d: CaptureOptions.from_dict(config["datasets"][d].get("captures"))
        for d in CAPTURES
    }
    CAPTURE_FILES = {
        d: capture_files(
            config["datasets"][d].get("path"),
            flat=config["datasets"][d].get("oracle") == "human",
        )
        for d in CAPTURES
    }
    for d, files in CAPTURE_FILES.items():
        # a cube with no timing stops the run here, not in a reconstruction job
        check_timing(
            config["datasets"][d]["path"],
            files,
            CAPTURE_OPTIONS[d],
            f"datasets.{d}.captures.bin_width_ps",
        )
        if workflow.exec_mode == ExecMode.DEFAULT:  # once, not in every job
            for line in not_read(config["datasets"][d]["path"]):
                logger.info(f"{d}: {line}")
    CAPTURE_SHARDS = {
        d: shard_count(CAPTURE_OPTIONS[d], len(f)) for d, f in CAPTURE_FILES.items()
    }
except ValueError as err:
    sys.exit(f"Error: {err}")


def capture_shards(dataset):
    return CAPTURE_SHARDS[dataset]


def capture_inputs(dataset, shard):
    """The capture files reconstruction shard ``shard`` of a captures dataset reads."""
    root = Path(config["datasets"][dataset]["path"])
    files = shard_of(CAPTURE_FILES[dataset], CAPTURE_SHARDS[dataset], shard)
    return [str(root / name) for name in files]


def capture_release(dataset):
    """The reconstructed release-layout folder of a captures dataset (none otherwise)."""
    return f"{RESULTS}/{dataset}/captures/release" if dataset in CAPTURES else []
