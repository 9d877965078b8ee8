"""Text from a calibration file made safe where exports write it: C comments, YAML comments and scalars.

A calibration file's text entries are checked on loading
(:func:`imucalib.calibration.check_document`); a calibration made in Python
is not, and every export escapes its text again where it writes it:

* :func:`comment_text` keeps printable ASCII other than ``\\`` and writes every
  other character as ``<U+XXXX>``: no line break (``\\n``, ``\\r``, and the
  U+0085, U+2028 and U+2029 YAML also takes for one) can end a ``#`` comment;
* :func:`c_comment` does the same and breaks ``*/`` (the end of a C comment),
  ``/*`` (a nested one) and ``??`` (a trigraph: ``??/`` is a backslash);
* :func:`yaml_scalar` is a plain scalar when the text is a plain word (a ROS
  topic name), else a double-quoted one with every character outside
  printable ASCII escaped (``\\xXX``, ``\\uXXXX``, ``\\UXXXXXXXX``).
"""

from __future__ import annotations

import re

__all__ = ["c_comment", "comment_text", "yaml_scalar"]

_PLAIN = re.compile(r"/?[A-Za-z][A-Za-z0-9_/]*")
#: words YAML 1.1 reads as booleans or null
_WORDS = {"y", "n", "yes", "no", "on", "off", "true", "false", "null"}


def comment_text(text: object) -> str:
    """``text`` as printable ASCII that cannot end a comment line: other characters as ``<U+XXXX>``."""
    return "".join(c if " " <= c <= "~" and c != "\\" else f"<U+{ord(c):04X}>" for c in str(text))


def c_comment(text: object) -> str:
    """``text`` for the inside of a C block comment: :func:`comment_text`, ``*/``, ``/*`` and ``??`` broken."""
    out = comment_text(text)
    for seq, safe in (("*/", "*<U+002F>"), ("/*", "/<U+002A>"), ("??", "?<U+003F>")):
        while seq in out:
            out = out.replace(seq, safe)
    return out


def yaml_scalar(text: str) -> str:
    """A YAML scalar that reads back as ``text``: plain for a word such as ``/imu0``, else double-quoted."""
    if _PLAIN.fullmatch(text) and text.lower() not in _WORDS:
        return text
    return '"' + "".join(_yaml_char(c) for c in text) + '"'


def _yaml_char(c: str) -> str:
    """One character of a double-quoted YAML scalar (YAML 1.1 and 1.2 section 5.7 escapes)."""
    if " " <= c <= "~":
        return "\\" + c if c in '"\\' else c
    code = ord(c)
    return f"\\x{code:02X}" if code < 0x100 else f"\\u{code:04X}" if code < 0x10000 else f"\\U{code:08X}"
