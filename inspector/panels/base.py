"""The base of the panel controllers."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator

from inspector.context import Context

__all__ = ["Panel"]


class Panel:
    """A panel controller: builds its controls in the tab it is given and handles them.

    Viser runs a control's callbacks when Python sets its value too; a panel sets its own
    controls :meth:`quietly`, and its callbacks that act on a user's choice return at once
    while :attr:`quiet` is true.

    Parameters
    ----------
    context : Context
        What the panels share; the only way to the other panels.
    """

    def __init__(self, context: Context) -> None:
        self.context = context
        self._quiet = False

    def build(self, gui: Any) -> None:
        """Add the panel's controls to ``gui`` (inside its tab) and attach their callbacks."""
        raise NotImplementedError

    @property
    def quiet(self) -> bool:
        """True while the panel sets its own controls."""
        return self._quiet

    @contextmanager
    def quietly(self) -> Iterator[None]:
        """A block in which the panel's callbacks ignore changes of its controls."""
        self._quiet = True
        try:
            yield
        finally:
            self._quiet = False

    def set_quietly(self, handle: Any, value: Any) -> None:
        """Set control ``handle`` to ``value`` without the panel acting on it as a choice."""
        with self.quietly():
            handle.value = value
