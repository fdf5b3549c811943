"""A numba event listener for scripts the tests run in a fresh process (with ``tests/`` on
their path): which functions that process compiles."""

from __future__ import annotations

from numba.core import event


class Compiled(event.Listener):
    """The qualified names (``module.qualname``) of the functions compiled while registered."""

    def __init__(self) -> None:
        self.names: list[str] = []

    def on_start(self, ev) -> None:
        pass

    def on_end(self, ev) -> None:
        f = ev.data["dispatcher"].py_func
        self.names.append(f"{f.__module__}.{f.__qualname__}")
