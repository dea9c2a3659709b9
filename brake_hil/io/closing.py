"""A resource that ``with`` closes: one ``__enter__``/``__exit__`` for the I/O classes (ROS-free).

A subclass defines ``close()``; ``with resource:`` returns the resource itself and closes it
on leaving, error or not. A subclass that must do something on entering (open a bus) extends
``__enter__`` and returns ``super().__enter__()``.
"""

from __future__ import annotations

from abc import abstractmethod
import contextlib
from types import TracebackType
from typing import Self

__all__ = ["Closing"]


class Closing(contextlib.AbstractContextManager["Closing", None]):
    """Closed on leaving a ``with`` block."""

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    @abstractmethod
    def close(self) -> None:
        """Release the resource (idempotent)."""
