"""The capture-format contract and the registry every format module registers into.

A capture format reads one kind of file into a ``spl_al.photon.capture.Capture``. A
format module registers itself once, at import::

    register(CaptureFormat(name="mine", suffixes=(".mine",), read=read_mine,
                           describe="a .mine file", files=".mine"))

The contract (``tests/test_capture_formats_contract.py`` checks every registered
format against it):

- ``read(path, options, variables)`` returns the capture of ``path``: events binned
  from 0 at the gate start, bin width, number of bins, gate start. ``options`` is the
  ``FileOptions`` of the call (options a format does not use are ignored);
  ``variables`` holds a ``.mat`` file's variables, already read once by
  ``load_capture`` for detection, else None. The same file gives the same bits.
- A bad file (unreadable, truncated, empty, an unknown layout) is a ``ValueError`` of
  one sentence naming the file.
- Formats that share a suffix (``.mat`` holds sparse, timestamp and cube variants)
  tell themselves apart by ``detect(variables)``: the names of the variables this
  format would read (cheap: no photons decoded). ``format="auto"`` tries the formats
  of the suffix in registration order and takes the first whose candidates hold the
  ``key`` option (or any, without a key).

``spl_al.photon.io.load_capture`` dispatches through ``get``; ``FORMATS``,
``CAPTURE_SUFFIXES``, ``SUPPORTED_FORMATS`` and ``is_capture`` derive from the registry.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from spl_al.photon.capture import Capture

# The one suffix whose files several formats share: its variables are read once
# (``spl_al.photon.formats.matfile.read_mat``) and handed to ``detect`` and ``read``.
MAT_SUFFIX = ".mat"


@dataclass(frozen=True)
class FileOptions:
    """How one file is read (``spl_al.photon.io`` documents each option); seconds."""

    key: str | None = None
    time_unit: str = "ps"
    unit_s: float = 1e-12
    bin_width_s: float | None = None
    gate_s: tuple[float, float] | None = None
    shape: tuple[int, int] | None = None
    order: str = "F"
    time_axis: int | None = None
    channel: int | None = None


Reader = Callable[[Path, FileOptions, "dict | None"], Capture]


@dataclass(frozen=True)
class CaptureFormat:
    """One registered capture format.

    Attributes:
        name: the ``format=`` name configs and the command line use.
        suffixes: lower-case file suffixes it reads (``format="auto"`` picks by these).
        read: ``read(path, options, variables) -> Capture`` (see the module docstring).
        describe: its words in the one line that lists what is supported
            ("a PicoQuant .ptu image").
        files: its files in the short list of supported files (".ptu"); formats
            sharing a phrase share it once.
        detect: ``detect(variables) -> names`` for a format of a shared suffix (``.mat``).
        any_suffix: read a file of any suffix when asked for by name (a format whose
            reader checks the file's own header, as PTU does).
    """

    name: str
    suffixes: tuple[str, ...]
    read: Reader
    describe: str
    files: str
    detect: Callable[[dict], list[str]] | None = None
    any_suffix: bool = False


_REGISTRY: dict[str, CaptureFormat] = {}


def register(fmt: CaptureFormat) -> CaptureFormat:
    """Add ``fmt`` under its name (registration order is ``auto``'s detection order)."""
    if not fmt.name or fmt.name == "auto" or fmt.name in _REGISTRY:
        raise ValueError(
            f"capture format name {fmt.name!r} is empty, 'auto' or already registered."
        )
    if MAT_SUFFIX in fmt.suffixes and fmt.detect is None:
        raise ValueError(f"capture format {fmt.name!r} reads {MAT_SUFFIX} but has no detect.")
    _REGISTRY[fmt.name] = fmt
    return fmt


def names() -> list[str]:
    """Names of the registered capture formats, in registration order."""
    return list(_REGISTRY)


def get(name: str) -> CaptureFormat:
    """The format ``name``; a ValueError naming the known ones (``auto`` first)."""
    if name not in _REGISTRY:
        raise ValueError(
            f"format {name!r} is not known; expected one of {', '.join(['auto', *names()])}."
        )
    return _REGISTRY[name]


def of_suffix(suffix: str) -> list[CaptureFormat]:
    """The formats that read files of ``suffix`` (lower case), in registration order."""
    return [fmt for fmt in _REGISTRY.values() if suffix in fmt.suffixes]


def suffixes() -> tuple[str, ...]:
    """Every suffix a registered format reads, each once, in registration order."""
    return tuple(dict.fromkeys(s for fmt in _REGISTRY.values() for s in fmt.suffixes))


def files_in_words() -> str:
    """The supported files in a few words: the formats' ``files`` phrases, sorted."""
    return ", ".join(sorted({fmt.files for fmt in _REGISTRY.values()}))


def formats_in_words() -> str:
    """Every format's ``describe``, as one list ("a, b, or c")."""
    words = [fmt.describe for fmt in _REGISTRY.values()]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])}, or {words[-1]}"
