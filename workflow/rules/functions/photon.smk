# Input functions of workflow/rules/photon.smk: the real captures to picture.
import functools
import shlex

from spl_al.config import real_captures_dir
from spl_al.data.raw_captures import not_read, picture_files
from spl_al.photon.io import ReadOptions

try:
    # photon.real_captures, else $SPL_AL_REAL_CAPTURES, else None (no pictures)
    REAL_CAPTURES = real_captures_dir(config)
    # how the pictures read their captures: a dataset's `captures:` reader options
    PICTURE_OPTIONS = ReadOptions.from_dict(
        config["photon"].get("real_capture_options"), "photon.real_capture_options"
    )
except ValueError as err:
    sys.exit(f"Error: {err}")


@functools.cache  # once per run: it names every file it leaves out
def real_capture_files():
    """{name: file} of the real captures to picture (none without a captures folder):
    every file of a capture format, read with photon.real_capture_options, named by
    its stem. A file of another format is named once, with the supported formats."""
    if REAL_CAPTURES is None:
        return {}
    if workflow.exec_mode == ExecMode.DEFAULT:  # once, not in every job
        for line in not_read(REAL_CAPTURES, recursive=False):
            logger.info(f"real captures: {line}")
    try:
        return picture_files(
            REAL_CAPTURES, PICTURE_OPTIONS, "photon.real_capture_options.bin_width_ps"
        )
    except ValueError as err:
        sys.exit(f"Error: {err}")


def photon_pictures():
    return [f"{RESULTS}/photon/conditions.png"] + expand(
        f"{RESULTS}/photon/real/{{capture}}.png", capture=list(real_capture_files())
    )


def sspi_args(flag=""):
    """Command-line options naming SSPI's weights when config photon.sspi_weights is set."""
    folder = config["photon"].get("sspi_weights")
    return f"{flag} --weights {shlex.quote(str(folder))}".strip() if folder else ""
