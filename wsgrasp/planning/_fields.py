"""Dataclass fields kept in a cheaper form than they are read in: the feasible
candidates' holdings (``holdings.HoldingField``: kept as ``Holdings``, read as the
bool mask) and a candidate set's poses (``result.PoseField``: kept as a
``PoseArray``, read as the ``(C, 4, 4)`` array).
"""

from __future__ import annotations

from typing import Any

__all__ = ["BuiltOnRead"]


class BuiltOnRead:
    """A dataclass field set as the value or its cheaper form (stored as
    :meth:`keep` makes it), read as the value (:meth:`read` builds it). The class
    declaring one declares the field's type for readers under ``TYPE_CHECKING``.

    The field has no default: reading it on the class raises AttributeError,
    which is how ``dataclasses`` tells a descriptor that supplies none.
    """

    def __set_name__(self, owner: type, name: str) -> None:
        self._slot = "_" + name

    def __get__(self, obj: Any, objtype: type | None = None) -> Any:
        if obj is None:
            raise AttributeError(self._slot[1:])
        return self.read(obj.__dict__[self._slot])

    def __set__(self, obj: Any, value: Any) -> None:
        obj.__dict__[self._slot] = self.keep(value)

    def stored(self, obj: Any) -> Any:
        """What ``obj`` keeps for the field, not built into the value."""
        return obj.__dict__[self._slot]

    def read(self, stored: Any) -> Any:
        """The value, from what is kept."""
        return stored

    def keep(self, value: Any) -> Any:
        """What to keep for a value set."""
        return value
