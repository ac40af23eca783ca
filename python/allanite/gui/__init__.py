"""Desktop GUI (PySide6, the ``gui`` extra): ``allanite gui`` or :func:`launch`.

The window (:mod:`allanite.gui.window`) is a thin Qt view over the Qt-free
:class:`~allanite.gui.session.Session`, which holds the record, results, fits and diagnosis.
"""

from __future__ import annotations

from typing import Any

from allanite.extras import require
from allanite.gui.session import DISPLAY_UNITS, Options, Session

__all__ = ["DISPLAY_UNITS", "Options", "Session", "create_window", "launch"]


def _qt() -> Any:
    return require("PySide6.QtWidgets", extra="gui", purpose="the GUI")


def create_window(session: Session | None = None) -> Any:
    """Create the main window (a QApplication is created if none exists)."""
    qt = _qt()
    app = qt.QApplication.instance() or qt.QApplication(["allanite"])
    from allanite.gui.window import MainWindow

    window = MainWindow(session)
    window.setProperty("app", app)
    return window


def launch(path: str | None = None, *, record: Any = None, **options: Any) -> int:
    """Open the window (optionally with a file or a record) and run the event loop."""
    qt = _qt()
    window = create_window()
    for name, value in options.items():
        if value is not None:
            setattr(window.session.options, name, value)
    if options.get("fs"):
        window.fs_spin.setValue(float(options["fs"]))
    if options.get("points"):
        window.points_spin.setValue(int(options["points"]))
    if options.get("units"):
        window.units_combo.setCurrentText(options["units"])
    if options.get("input"):
        window.input_combo.setCurrentText(options["input"])
    if path is not None:
        window._guard(lambda: window.open_file(path))()
    elif record is not None:
        window._guard(lambda: window.use_record(record))()
    window.show()
    return int(qt.QApplication.instance().exec())
