"""The architectures ``build_model`` knows: one ``register`` per model class.

A model module decorates its class with ``@register(task, name)`` (``default=True`` for
the architecture a task gets when a config names none), and ``spl_al.models`` imports
the module, so that ``ARCHS[task][name]`` is the class. The config schema's ``arch``
enum lists exactly these names (a test keeps them equal).
"""

from __future__ import annotations

from collections.abc import Callable

from spl_al.data.dataset import TASKS

ARCHS: dict[str, dict[str, type]] = {task: {} for task in TASKS}
"""task -> {architecture name: model class}, the task's default first."""


def register(task: str, name: str, *, default: bool = False) -> Callable[[type], type]:
    """Class decorator: ``build_model(task, n_classes, arch=name)`` builds the class;
    with ``default`` it is what a config without ``arch`` gets for ``task``.

    Raises:
        ValueError: an unknown task, or a name already taken by another class.
    """
    if task not in ARCHS:
        raise ValueError(f"task must be one of {TASKS}, got {task!r}.")

    def add(cls: type) -> type:
        taken = ARCHS[task].get(name)
        if taken is not None and taken is not cls:
            raise ValueError(
                f"arch {name!r} for task {task!r} is already registered as {taken.__name__}."
            )
        archs = {name: cls, **ARCHS[task]} if default else {**ARCHS[task], name: cls}
        ARCHS[task].clear()
        ARCHS[task].update(archs)
        return cls

    return add
