"""The one datasheet module: both formats, JSON/YAML files, the pass/marginal/fail rule."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from allanite.datasheet import (
    Datasheet,
    Limit,
    Measured,
    check_limits,
    undetected_measured,
    verdict,
)
from allanite.errors import InputError

FULL = {
    "device": "Demo",
    "limits": [
        {"quantity": "N", "max": 0.3, "unit": "deg/sqrt(h)"},
        {"quantity": "adev", "tau": 1, "max": 0.01, "unit": "deg/s"},
    ],
}
# a flat Allan deviation of 0.005 deg/s with a +-10 % interval
CURVE = (
    np.array([0.1, 1.0, 10.0]),
    np.full(3, 0.005),
    np.full(3, 0.0045),
    np.full(3, 0.0055),
    "deg/s",
)


def test_both_forms_build_the_same_limits() -> None:
    full = Datasheet.from_dict(FULL)
    assert full.limits[0] == Limit("N", "deg/sqrt(h)", max=0.3)
    assert full.quantities == ("N", "adev")
    compact = Datasheet.from_dict({"device": "lot", "N": 0.01, "K": {"min": 0, "max": 1e-4}})
    assert compact.device == "lot"
    assert compact.limits == (Limit("N", "", max=0.01), Limit("K", "", max=1e-4, min=0.0))
    assert Datasheet.coerce(FULL) == full
    assert Datasheet.coerce(full) is full
    assert Datasheet.coerce(None) is None
    with pytest.raises(TypeError, match="datasheet must be"):
        Datasheet.coerce(0.3)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="'adev' limit needs tau"):
        Datasheet.from_dict({"adev": 0.01})
    with pytest.raises(InputError, match="at least one bound"):
        Datasheet.from_dict({"N": {}})


def test_json_and_yaml_files(tmp_path: Path) -> None:
    js = tmp_path / "sheet.json"
    js.write_text('{"N": 0.01, "B": {"max": 0.003}}')
    yml = tmp_path / "sheet.yml"
    yml.write_text("N: 0.01\nB:\n  max: 0.003\n")
    assert Datasheet.load(js).limits == Datasheet.load(yml).limits
    assert Datasheet.load(js).device == "sheet"
    bad = tmp_path / "bad.yaml"
    bad.write_text("N: [0.01\n")
    with pytest.raises(InputError, match=r"bad.yaml, line \d+: not valid YAML"):
        Datasheet.load(bad)
    with pytest.raises(InputError, match="no such file"):
        Datasheet.load(tmp_path / "none.json")


def test_status_from_the_interval() -> None:
    sheet = Datasheet.from_dict({"N": 1.0})
    statuses = [
        check_limits(sheet, "x", {"N": Measured(v, lo, hi, "deg/sqrt(s)", "deg/sqrt(s)")}, CURVE)[
            0
        ].status
        for v, lo, hi in ((0.5, 0.4, 0.6), (0.9, 0.8, 1.1), (1.1, 0.9, 1.3))
    ]
    assert statuses == ["pass", "marginal", "fail"]
    # units converted: 0.06 deg/sqrt(h) = 0.001 deg/sqrt(s)
    full = Datasheet.from_dict(FULL)
    n = Measured(0.001, 0.0009, 0.0011, "deg/sqrt(s)", "deg/sqrt(s)")
    checks = check_limits(full, "x", {"N": n}, CURVE)
    assert checks[0].value == pytest.approx(0.06)
    assert [c.status for c in checks] == ["pass", "pass"]


def test_absent_terms_and_the_verdict() -> None:
    sheet = Datasheet.from_dict({"R": {"min": 1.0}, "K": {"min": 0.0, "max": 1.0}, "B": 1.0})
    checks = check_limits(sheet, "x", {}, CURVE)
    # a term the fit did not find fails a positive minimum and is otherwise not measured
    assert [c.status for c in checks] == ["fail", "missing", "missing"]
    assert verdict([c.status for c in checks]) == "fail"
    assert verdict(["pass", "missing", "marginal"]) == "marginal"
    assert verdict(["missing"]) == "pass"
    assert verdict([]) == "pass"
    # an Allan deviation limit outside the measured taus is not measured either
    far = Datasheet.from_dict(
        {"limits": [{"quantity": "adev", "tau": 100, "min": 1.0, "unit": "deg/s"}]}
    )
    assert check_limits(far, "x", {}, CURVE)[0].status == "missing"


def test_undetected_terms_are_judged_by_their_upper_limit() -> None:
    """B not fitted but bounded (FitResult.undetected): PASS when the upper limit meets the
    limit, UNDETERMINED when it does not; against a positive minimum FAIL below it."""
    # upper limit 2 deg/h (in the model's units, deg/s)
    bound = {"B": Measured(0.0, 0.0, 2.0 / 3600.0, "deg/s", "deg/s")}
    sheet = Datasheet.from_dict(
        {
            "limits": [
                {"quantity": "B", "max": 5.0, "unit": "deg/h"},
                {"quantity": "B", "max": 1.0, "unit": "deg/h"},
                {"quantity": "B", "min": 3.0, "unit": "deg/h"},
                {"quantity": "B", "min": 1.0, "unit": "deg/h"},
                {"quantity": "B", "min": 0.0, "unit": "deg/h"},
            ]
        }
    )
    checks = check_limits(sheet, "gx", {}, CURVE, bound)
    assert [c.status for c in checks] == ["pass", "undetermined", "fail", "undetermined", "pass"]
    assert all(c.value is None and c.upper == pytest.approx(2.0) for c in checks)
    assert checks[1].status_text() == "NOT DETERMINED (<= 2)"
    assert checks[0].status_text() == "PASS (not detected, <= 2)"
    assert checks[1].to_dict()["upper"] == pytest.approx(2.0)
    # a fitted value wins over a bound; without the bound the old rules hold
    fitted = {"B": Measured(1e-4, 5e-5, 2e-4, "deg/s", "deg/s")}
    assert check_limits(sheet, "gx", fitted, CURVE, bound)[0].status == "pass"
    assert check_limits(sheet, "gx", fitted, CURVE, bound)[0].upper is None
    assert [c.status for c in check_limits(sheet, "gx", {}, CURVE)][:3] == [
        "missing",
        "missing",
        "fail",
    ]
    # compact limits (record units) too
    compact = Datasheet.from_dict({"B": 1e-4})
    assert check_limits(compact, "gx", {}, CURVE, bound)[0].status == "undetermined"
    # the verdict: fail > marginal > undetermined > pass
    assert verdict(["pass", "undetermined", "missing"]) == "undetermined"
    assert verdict(["undetermined", "marginal"]) == "marginal"
    assert verdict(["undetermined", "fail"]) == "fail"


def test_undetected_measured_from_a_fit() -> None:
    """The bounds come from the fit: every auto-fit candidate left out, none for a model."""
    import allanite
    from allanite.fit import fit

    rng = np.random.default_rng(5)
    res = allanite.avar(0.01 * rng.standard_normal(50_000), fs=100.0, units="deg/s")
    f = fit(res)
    bounds = undetected_measured(f, 0.95)
    assert set(bounds) == {*f.undetected, *f.exchangeable} - set(f.coefficients)
    assert "B" in bounds
    assert "N" not in bounds
    assert bounds["B"].high == pytest.approx(f.undetected["B"].ci(0.95)[1])
    assert undetected_measured(f.model, 0.95) == {}


def test_report_shows_upper_limits_and_undetermined(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The HTML report: the left-out terms' upper limits under the fit, and a datasheet
    limit on one of them judged by it (UNDETERMINED / PASS, the bound shown)."""
    from allanite.cli import main

    rng = np.random.default_rng(5)
    rec = tmp_path / "rate.npy"
    np.save(rec, 0.01 * rng.standard_normal(50_000))
    sheet = tmp_path / "sheet.json"
    sheet.write_text(
        '{"limits": [{"quantity": "R", "max": 1e-9, "unit": "deg/h^2"},'
        ' {"quantity": "R", "max": 1e9, "unit": "deg/h^2"}]}'
    )
    out = tmp_path / "r.html"
    argv = ["report", str(rec), "--fs", "100", "--units", "deg/s", "--datasheet", str(sheet)]
    assert main([*argv, "-o", str(out)]) == 0
    html = out.read_text()
    assert "not detected (95 % upper limits): " in html
    assert ">NOT DETERMINED<" in html  # the badge says what the CLI prints
    assert "datasheet sheet: NOT DETERMINED" in capsys.readouterr().out
    assert "(not detected)" in html
