"""One exception type for every input or setting problem a user can fix.

Readers and validators raise :class:`IPFError` with the offending file (when there is one) and a
short statement of what is wrong; the CLI prints ``error: <file>: <problem>`` on one line and exits
with status 2. Anything else escaping to the CLI is a bug and keeps its traceback.
"""
from __future__ import annotations

from pathlib import Path


class IPFError(Exception):
    """A user-facing error: bad input file, impossible setting, unusable data."""

    def __init__(self, message: str, path: str | Path | None = None):
        self.path = None if path is None else str(path)
        self.message = " ".join(str(message).split())  # one line, whatever a library said
        super().__init__(f"{self.path}: {self.message}" if self.path else self.message)


class IPFWarning(UserWarning):
    """Something the user should know (a partial frame range, a bridged gap); the CLI prints it
    as one ``warning: <message>`` line."""


def require(condition: bool, message: str, path: str | Path | None = None) -> None:
    """Raise :class:`IPFError` unless ``condition`` holds."""
    if not condition:
        raise IPFError(message, path)


def load_json(path: str | Path, what: str = "file", *, missing_hint: str = ""):
    """The JSON document in ``path``; a missing or unreadable file is an :class:`IPFError` naming
    ``what`` it should have been (``"shape file"``, ``"marker map"``, ...)."""
    import json

    path = Path(path)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise IPFError(f"{what} not found{missing_hint}", path) from None
    except (OSError, ValueError) as e:
        raise IPFError(f"{what} is not readable JSON ({e})", path) from None
