"""GUI offscreen: load a file, set fs/points/channels/units, switch views, screenshot, export."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
pytest.importorskip("PySide6.QtWidgets", reason="the GUI needs PySide6 (the 'gui' extra)")

import allanite
from allanite.gui import create_window
from allanite.gui.window import VIEWS

RNG = np.random.default_rng(5)
FS = 50.0
N = 4000


@pytest.fixture
def record_file(tmp_path: Path) -> tuple[Path, np.ndarray]:
    data = RNG.normal(size=(N, 2)) * np.array([0.2, 0.4])
    t = np.arange(N) / FS
    path = tmp_path / "stand.csv"
    rows = "\n".join(f"{a:.6f},{b:.17g},{c:.17g}" for a, (b, c) in zip(t, data, strict=True))
    path.write_text("t,gx,gy\n" + rows + "\n")
    return path, data


def test_gui_load_switch_views_screenshot_export(
    record_file: tuple[Path, np.ndarray], tmp_path: Path
) -> None:
    path, data = record_file
    window = create_window()
    window.resize(1200, 800)
    window.show()
    window.fs_spin.setValue(0.0)  # "from time column"
    window.time_edit.setText("t")
    window.units_combo.setCurrentText("deg/s")
    window.points_spin.setValue(25)
    record = window.open_file(path)
    assert record.fs == pytest.approx(FS)
    assert window.fs_spin.value() == pytest.approx(FS)
    assert window.channel_list.count() == 2
    assert "2 channel(s)" in window.status_label.text()
    result = window.session.result
    assert result is not None
    expected = allanite.avar(data, fs=FS, points=25)
    np.testing.assert_allclose(result.dev, expected.dev, rtol=1e-12)

    # grid points: recompute with fewer points
    window.points_spin.setValue(10)
    window.compute()
    assert window.session.result.tau.size == allanite.variance.taus.log_grid(N, 10).size

    # channel selection: only gy is drawn and listed
    window.channel_list.item(0).setCheckState(window.channel_list.item(0).checkState().Unchecked)
    assert window.selected_channels() == [1]
    channels = {window.table.item(r, 0).text() for r in range(window.table.rowCount())}
    assert channels == {"gy"}

    # unit choice: deg/h is 3600 deg/s
    window.display_combo.setCurrentText("deg/h")
    shown = window.session.display_result("deg/h")
    np.testing.assert_allclose(shown.dev, window.session.result.dev * 3600, rtol=1e-12)
    assert shown.units == "deg/h"

    # views: the fit either draws coefficients or says plainly that no fitter is installed
    window._guard(lambda: window.set_view("Fit"))()
    assert window.current_view() == "Fit"
    if window.table.rowCount() == 0:
        assert "fitting is not available" in window.status_label.text()
    else:
        assert window.table_title.text().startswith("Noise coefficients")
    window._guard(lambda: window.set_view("Diagnosis"))()
    assert "choose a model file" in window.status_label.text()
    window.set_view(VIEWS[0])
    assert window.table_title.text().startswith("Slopes of the measured curve")

    # diagnosis against a model file: white noise of the wrong level is a significant gap
    from allanite.model import NoiseModel
    from allanite.terms import TERM_TYPES

    model = tmp_path / "sim.json"
    white = TERM_TYPES["white"](N=0.1 / np.sqrt(FS))  # half the real gy noise (0.4 deg/s)
    model.write_text(NoiseModel(terms=(white,), units={"rate": "deg/s", "time": "s"}).to_json())
    window.session.options.n_mc = 20
    window.load_model(model)
    assert window.current_view() == "Diagnosis"
    assert window.model_label.text() == "sim.json"
    assert window.table_title.text().startswith("Diagnosis: significant gap")
    assert window.session.diagnosis_channel == 1
    window.set_view(VIEWS[0])

    shot = window.grab_screenshot(tmp_path / "gui.png")
    from PySide6.QtGui import QImage

    image = QImage(str(shot))
    assert image.width() >= 1000
    assert image.height() >= 700
    # the plot is drawn: count pixels of the first curve colour (matplotlib blue) in the image
    ptr = image.convertToFormat(QImage.Format.Format_RGB888)
    pixels = np.frombuffer(ptr.constBits(), dtype=np.uint8)
    pixels = pixels.reshape(ptr.height(), ptr.bytesPerLine())[:, : 3 * ptr.width()]
    rgb = pixels.reshape(ptr.height(), ptr.width(), 3).astype(int)
    blue = np.all(np.abs(rgb - np.array([0x1F, 0x77, 0xB4])) <= 12, axis=-1).sum()
    assert blue > 300
    assert rgb.std() > 20  # not a blank window

    report = window.export_report(tmp_path / "from_gui")
    assert report.suffix == ".html"
    html = report.read_text()
    assert "<h2>Allan deviation</h2>" in html
    assert "gy" in html
    window.close()


def test_gui_bad_file_shows_error_not_traceback(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("t,gx\n0,1\n0.01,zz\n0.02,3\n")
    window = create_window()
    window._guard(lambda: window.open_file(bad))()
    text = window.status_label.text()
    assert "bad.csv" in text
    assert "line 3" in text
    assert "b03a2e" in window.status_label.styleSheet()
    assert window.session.record is None
    window.close()


def test_gui_offers_the_units_of_an_accelerometer_record() -> None:
    from allanite.io import Record

    window = create_window()
    samples = RNG.normal(size=(N, 1)) * 0.01
    window.use_record(Record(samples=samples, fs=FS, units="m/s^2", channels=("ax",)))
    offered = [window.display_combo.itemText(i) for i in range(window.display_combo.count())]
    assert offered == ["as recorded", "m/s^2", "g", "mg", "ug"]
    window.display_combo.setCurrentText("mg")
    shown = window.session.display_result("mg")
    np.testing.assert_allclose(shown.dev, window.session.result.dev / (1e-3 * 9.80665), rtol=1e-12)
    assert "m/s^2" in [window.units_combo.itemText(i) for i in range(window.units_combo.count())]
    window.close()


def test_gui_labels_show_file_names_as_plain_text(tmp_path: Path) -> None:
    """A file name holding markup is shown as it is, not as a heading and a link (#31)."""
    from PySide6.QtCore import Qt

    data = np.random.default_rng(1).normal(size=(600, 1))
    path = tmp_path / "<h1>big<a href='x'>link.csv"  # no '/' in a file name
    np.savetxt(path, data)
    window = create_window()
    window.fs_spin.setValue(FS)
    window.open_file(path)
    assert window.file_label.text() == path.name
    for label in (window.file_label, window.model_label, window.status_label):
        assert label.textFormat() == Qt.TextFormat.PlainText
    window.close()


def test_gui_unexpected_error_is_shown_and_the_old_file_is_not_current(
    record_file: tuple[Path, np.ndarray], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An error outside the expected types is shown in the window; the file that was open
    before is no longer shown as current (#31)."""
    path, _ = record_file
    window = create_window()
    window.time_edit.setText("t")
    window.fs_spin.setValue(0.0)
    window.open_file(path)
    assert window.file_label.text() == "stand.csv"

    def broken(_path: object) -> None:
        raise KeyError("library defect")

    monkeypatch.setattr(window.session, "load", broken)
    window._guard(lambda: window.open_file(tmp_path / "other.csv"))()
    assert "KeyError" in window.status_label.text()
    assert "library defect" in window.status_label.text()
    assert "b03a2e" in window.status_label.styleSheet()
    assert window.file_label.text() == "no file"
    assert window.session.record is None
    assert window.channel_list.count() == 0
    window.close()
