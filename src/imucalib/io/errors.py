"""The error every reader raises for input it cannot read."""

from __future__ import annotations

__all__ = ["ReaderError"]


class ReaderError(ValueError):
    """Input that cannot be read; the message names the file, line/column and the fix."""
