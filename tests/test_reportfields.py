"""The fit report's fields are declared once: code reads and writes the typed records, not flat keys, every
method's calibration holds only declared fields, and a file with a field this version does not know still loads."""

import ast
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.methods import calibrate
from imucalib.models import TriadModel
from imucalib.recording import ImucalibWarning
from imucalib.reportfields import FIELDS, GROUPS, field, undeclared
from imucalib.scenarios import handheld, session

SRC = Path(__file__).resolve().parents[1] / "src" / "imucalib"


def _is_fit(node) -> bool:
    """``fit``, ``….fit`` or ``(….fit or {})``."""
    if isinstance(node, ast.Name):
        return node.id == "fit"
    if isinstance(node, ast.Attribute):
        return node.attr == "fit"
    if isinstance(node, ast.BoolOp) and isinstance(node.op, ast.Or):
        return _is_fit(node.values[0])
    return False


def _text(node) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def _dict_keys(node) -> list[str]:
    return [k for k in (_text(key) for key in node.keys if key is not None) if k] if isinstance(node, ast.Dict) else []


def fit_keys(tree: ast.AST) -> list[tuple[str, int]]:
    """Every literal key the code reads from or writes to a fit: ``fit["k"]``, ``fit.get("k")`` (``pop``,
    ``setdefault``), ``fit.update({…}, k=…)``, ``fit = {…}``, ``fit |= {…}`` and ``fit={…}`` in a call."""
    out = []
    for node in ast.walk(tree):
        keys: list[str] = []
        if isinstance(node, ast.Subscript) and _is_fit(node.value) and _text(node.slice):
            keys = [_text(node.slice)]
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and _is_fit(node.func.value):
            if node.func.attr in ("get", "pop", "setdefault") and node.args and _text(node.args[0]):
                keys = [_text(node.args[0])]
            elif node.func.attr == "update":
                keys = [k for a in node.args for k in _dict_keys(a)] + [kw.arg for kw in node.keywords if kw.arg]
        elif isinstance(node, ast.keyword) and node.arg == "fit":
            keys = _dict_keys(node.value)
        elif isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(_is_fit(t) for t in targets) and node.value is not None:
                keys = _dict_keys(node.value)
        out += [(k, getattr(node, "lineno", 0)) for k in keys]
    return out


def test_the_scan_finds_every_form():
    code = ('fit["a"]; cal.fit.get("b"); (cal.fit or {}).get("c"); fit.update({"d": 1}, e=2); fit = {"f": 1}\n'
            'fit |= {"g": 1}; cal.with_(fit={**cal.fit, "h": 1}); fit["i"] = 1; other["z"]; fit.pop("j", None)\n')
    assert sorted(k for k, _ in fit_keys(ast.parse(code))) == list("abcdefghij")


def test_no_module_reads_or_writes_a_fit_by_key():
    """The package reads and writes the fit report's typed records (imucalib.fitreport), never its flat keys."""
    found = [f"{path.relative_to(SRC)}:{line}: {key!r}" for path in sorted(SRC.rglob("*.py"))
             for key, line in fit_keys(ast.parse(path.read_text(encoding="utf-8")))]
    assert found == []
    # the scan does see string keys where there are some (the same code with the records' flat keys)
    assert [k for k, _ in fit_keys(ast.parse('cal.fit["verdict"]; fit.get("intervals"); fit["cost"] = 1'))] == \
        ["verdict", "intervals", "cost"]


def test_the_declaration_is_whole_and_grouped():
    names = [f.name for f in FIELDS]
    assert len(names) == len(set(names))
    assert all(f.group in GROUPS and f.meaning for f in FIELDS)
    assert field("verdict").group == "verdict"
    with pytest.raises(KeyError, match="not a declared field"):
        field("verdit")


@pytest.fixture(scope="module")
def calibrations():
    d = handheld.generate(np.random.default_rng(12), magnetometer=True)
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        for method in ("tedaldi2014", "ellipsoid", "six_position", "qureshi2017", "ferraris"):
            try:
                out[method] = calibrate(d["recording"], method=method)
            except ValueError:
                pass
        out["zhang2021"] = calibrate(session("zhang2021", rng=1), method="zhang2021", model="linear")
    return out


def test_every_methods_calibration_holds_declared_fields_only(calibrations):
    assert {"tedaldi2014", "zhang2021"} <= set(calibrations)
    assert calibrations["tedaldi2014"].magnetometer is not None  # the magnetometer's fields are checked too
    for method, cal in calibrations.items():
        assert undeclared(cal.fit) == [], method


def test_a_file_with_an_unknown_field_loads_it_kept_and_warned(tmp_path):
    cal = Calibration(TriadModel(), TriadModel(), method="tedaldi2014", model="linear",
                      fit={"static_intervals": 12, "verdict": "accepted"})
    doc = json.loads(cal.to_json())
    doc["fit"]["a_future_figure"] = [1.5, 2.5]
    path = tmp_path / "c.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.warns(ImucalibWarning, match="a_future_figure"):
        loaded = Calibration.load(path)
    assert loaded.fit["a_future_figure"] == [1.5, 2.5] and loaded.fit["static_intervals"] == 12
    out = tmp_path / "again.json"
    loaded.save(out)
    assert json.loads(out.read_text(encoding="utf-8"))["fit"] == doc["fit"]  # written back as read
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImucalibWarning)  # a file of declared fields loads without a word
        assert Calibration.from_dict(json.loads(cal.to_json())).fit == cal.fit
