"""Text from files, headers, keys and the store made safe to print on a terminal.

A file name, a CSV header, a calibration's key or an error kept in the store
can hold terminal control sequences: ``ESC [`` (CSI) sequences that move the
cursor, recolour or clear the screen, retitle the window (OSC ``ESC ]``) or,
on some terminals, answer back; a carriage return or backspace that
overwrites what was printed; Unicode's bidirectional overrides that show
text in another order than it is (CVE-2021-42574). :func:`printable` writes
each such character as a visible escape (``\\x1b``, ``\\u202e``), which is
how Python's ``repr`` shows them, so that what is printed is the text as it
is. OWASP's output-encoding rule: encode for the place the text goes.
"""

from __future__ import annotations

import re

__all__ = ["printable"]

#: C0 controls, DEL, C1 controls (0x9b is a one-character CSI), and the bidirectional formatting characters
_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def printable(text: object, keep: str = "\n\t") -> str:
    """``text`` (its ``str``) with every control character except those in ``keep`` written as an escape."""
    text = str(text)

    def escape(m: re.Match) -> str:
        c = m.group(0)
        if c in keep:
            return c
        code = ord(c)
        return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"

    return _UNSAFE.sub(escape, text)
