"""The error every reader raises for input it cannot read."""

from __future__ import annotations

__all__ = ["ReaderError"]


class ReaderError(ValueError):
    """Input that cannot be read; the message names the file, line/column and the fix.

    Examples
    --------
    Raised by the readers, with a message that names the file and what to change:

    >>> from imucalib.io import ReaderError, read
    >>> try:
    ...     read("no_such_file.csv")
    ... except ReaderError as exc:
    ...     print(exc)
    no_such_file.csv: file not found
    """
