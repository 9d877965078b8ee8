"""The fit report's fields as a flat table: every key a calibration file's ``fit`` may hold, with its unit,
meaning and group.

The fields are declared once, as the fields of the records of :mod:`imucalib.fitreport`
(:class:`~imucalib.fitreport.FitReport`, which :attr:`imucalib.calibration.Calibration.fit` holds); this table
is derived from them, for the documentation and for checks by key. A test calibrates with every method and
checks the keys it finds.

Reading a file with a field not declared (a file from an older or newer version) keeps the field as it was
read and warns once, naming it (:func:`undeclared`).
"""

from __future__ import annotations

from collections import namedtuple

from .fitreport import GROUPS, FitReport, declarations

__all__ = ["FIELDS", "GROUPS", "FieldInfo", "field", "undeclared"]


class FieldInfo(namedtuple("FieldInfo", "name unit meaning group")):
    """One field of the fit report.

    Attributes
    ----------
    name : str
        The key in ``Calibration.fit`` and in the file's ``fit`` object.
    unit : str
        Its unit (``""``: a count, a ratio, a name or text; for a list or mapping, its entries' unit).
    meaning : str
        What it holds, in one sentence.
    group : str
        The group it belongs to (a key of :data:`GROUPS`).
    """

    __slots__ = ()


#: every declared field, record by record (from the records of :mod:`imucalib.fitreport`)
FIELDS: tuple[FieldInfo, ...] = tuple(FieldInfo(*d) for d in declarations())

_BY_NAME = {f.name: f for f in FIELDS}


def field(name: str) -> FieldInfo:
    """The declaration of the field ``name``; a KeyError naming the field when it is not declared."""
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(f"{name!r} is not a declared field of the fit report (imucalib.reportfields.FIELDS)") from None


def undeclared(fit) -> list[str]:
    """The keys of a flat ``fit`` object that are not declared fields, in their order."""
    return FitReport.undeclared(fit)
