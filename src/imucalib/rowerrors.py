"""A batch row's error as stored: what it says of the row's files, and nothing more.

A manifest can name any file the batch may read (``/etc/shadow``), and a row's
error is kept in the store, which others may read. So the stored error quotes
a file's content only as far as it helps: every quoted excerpt is cut to
:data:`EXCERPT_CHARS` characters, and any longer run of a file's first bytes
to nothing; of a file that is no recording (no line of three numbers in its
first bytes), nothing longer than a few characters is kept.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Sequence
from pathlib import Path

from .io.inputs import path_kind

__all__ = ["EXCERPT_CHARS", "heads_of", "row_message"]

#: the most characters of a file's content a stored error quotes
EXCERPT_CHARS = 16


#: a quoted excerpt in a message: '…' or "…" (Python's repr of a string), at least one character long
_QUOTED = re.compile(r"'((?:[^'\\\n]|\\.)+)'" + r'|"((?:[^"\\\n]|\\.)+)"')


def _short_quotes(text: str, limit: int = EXCERPT_CHARS) -> str:
    """``text`` with every quoted excerpt longer than ``limit`` characters cut to its first ``limit``."""
    def cut(m: re.Match) -> str:
        inner = m.group(1) if m.group(1) is not None else m.group(2)
        if len(inner) <= limit:
            return m.group(0)
        q = m.group(0)[0]
        return f"{q}{inner[:limit]}…{q}"

    return _QUOTED.sub(cut, text)


#: the bytes at the start of each file whose text a row's error may not quote at length
_CONTENT_BYTES = 1 << 16


def heads_of(paths: Sequence[Path | None]) -> list[str]:
    """The first :data:`_CONTENT_BYTES` of each regular file of ``paths``, as text."""
    out = []
    for p in paths:
        if p is None:
            continue
        with contextlib.suppress(OSError):
            if p.is_file() and path_kind(p.stat().st_mode) is None:
                with open(p, "rb") as fh:
                    out.append(fh.read(_CONTENT_BYTES).decode("utf-8", errors="replace"))
    return out


#: the longest run of a file that is no recording that a stored error may hold [characters]
_STRANGER_CHARS = 3
_NUMBER = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")


def _looks_like_recording(head: str) -> bool:
    """Whether the first bytes of a file hold a line of at least three numbers (a row of readings), cells
    split at commas, semicolons, tabs or spaces."""
    for line in head.splitlines()[:200]:
        cells = [c for c in re.split(r"[,;\t ]+", line.strip()) if c]
        if sum(bool(_NUMBER.match(c)) for c in cells) >= 3:
            return True
    return False


def _cut_content(text: str, heads: Sequence[str], limit: int = EXCERPT_CHARS) -> str:
    """``text`` with every run of more than ``limit`` characters that is found in one of ``heads`` cut to
    its first ``limit`` characters."""
    if not heads:
        return text
    out, i, n = [], 0, len(text)
    while i < n:
        j = i + limit + 1
        if j <= n and any(text[i:j] in h for h in heads):
            while j < n and any(text[i:j + 1] in h for h in heads):
                j += 1
            out.append("…")  # nothing of it: its first characters are what a secret's file starts with
            i = j
        else:
            out.append(text[i])
            i += 1
    return "".join(out)


def row_message(exc: BaseException, replace: dict[str, str], paths: Sequence[str] = (),
             heads: Sequence[str] = ()) -> str:
    """An exception as the row's error: its message (with the type for unexpected kinds), local copies named
    by their URLs, quoted file content and text found in ``heads`` (the start of the row's files) cut to
    :data:`EXCERPT_CHARS` characters (the row's own paths kept)."""
    text = str(exc) if isinstance(exc, ValueError | OSError) else f"{type(exc).__name__}: {exc}"
    for local, original in replace.items():
        text = text.replace(local, original)
    keep = {f"\0{k}\0": p for k, p in enumerate(sorted({*paths, *replace.values()}, key=len, reverse=True))}
    for key, p in keep.items():
        text = text.replace(p, key)
    # a file that is no recording (/etc/shadow): nothing of it longer than a few characters
    strangers = [h for h in heads if not _looks_like_recording(h)]
    text = _short_quotes(_cut_content(_cut_content(text, strangers, _STRANGER_CHARS), heads))
    for key, p in keep.items():
        text = text.replace(key, p)
    return text or type(exc).__name__
