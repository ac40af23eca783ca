"""The main window of the GUI.

Open a file, set fs and grid points, switch Allan deviation / fit / diagnosis, pick channels
and units, read the coefficients, export the report.

The window is a thin view over :class:`allanite.gui.session.Session`; errors the user can fix
are shown in the status line (red), never as tracebacks.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from PySide6 import QtCore, QtGui, QtWidgets

from allanite.gui.session import DISPLAY_UNITS, RECORD_UNITS, Session, display_units_for
from allanite.io.record import INPUT_KINDS, Record

__all__ = ["VIEWS", "MainWindow"]

#: the views of the plot area
VIEWS: tuple[str, ...] = ("Allan deviation", "Fit", "Diagnosis")
_FILE_FILTER = (
    "Records (*.txt *.csv *.tsv *.dat *.asc *.gz *.npy *.npz *.h5 *.hdf5 *.parquet *.bin *.raw);;"
    "All files (*)"
)
_USER_ERRORS = (ValueError, TypeError, OSError, IndexError)


def _numeric(text: str) -> bool:
    """Whether a table cell holds a number or an interval (right-aligned)."""
    head = text.split("…")[0].strip().lstrip("+-−")
    return bool(head) and (head[0].isdigit() or head.startswith("."))


def _goodness_text(fit: Any, channel: str) -> str:
    """`` — fit of <channel>: p = ...`` with a warning when the model misses the curve."""
    from allanite.report.build import MISFIT_P

    p = getattr(fit, "p_value", None)
    if p is None or p != p:
        return ""
    if p < MISFIT_P:
        return f" — ⚠ the model does not describe {channel}'s curve (p = {p:.2g})"
    return f" — fit of {channel}: p = {p:.2g}"


class MainWindow(QtWidgets.QMainWindow):
    """allanite's desktop window."""

    def __init__(self, session: Session | None = None) -> None:
        super().__init__()
        self.session = session or Session()
        self.setWindowTitle("allanite — gyroscope noise analysis")
        self.resize(1280, 820)
        self._canvas: Any = None
        self._info = ""
        self._build()
        self._set_status("Open a record file (File ▸ Open, or the Open… button).")

    # --- layout -------------------------------------------------------------------------------
    def _build(self) -> None:
        panel = QtWidgets.QWidget()
        side = QtWidgets.QVBoxLayout(panel)
        side.setContentsMargins(8, 8, 8, 8)
        side.addWidget(self._record_box())
        side.addWidget(self._channel_box())
        side.addWidget(self._view_box())
        side.addWidget(self._diagnosis_box())
        self.export_button = QtWidgets.QPushButton("Export report…")
        self.export_button.clicked.connect(self._ask_export)
        side.addWidget(self.export_button)
        side.addStretch(1)
        scroll = QtWidgets.QScrollArea()
        scroll.setWidget(panel)
        scroll.setWidgetResizable(True)
        scroll.setMinimumWidth(330)
        scroll.setMaximumWidth(380)
        main = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        main.addWidget(scroll)
        main.addWidget(self._results_area())
        main.setStretchFactor(1, 1)
        self.setCentralWidget(main)
        self.status_label = QtWidgets.QLabel()
        self.statusBar().addWidget(self.status_label, 1)
        self._build_menu()
        for label in (self.status_label, self.file_label, self.model_label, self.table_title):
            # file names and messages are text, never markup (a name may hold <h1> or <a href>)
            label.setTextFormat(QtCore.Qt.TextFormat.PlainText)
        self._show_figure(self._empty_figure())

    def _record_box(self) -> QtWidgets.QGroupBox:
        """File, sampling frequency, input kind, units, scale, time column, key, grid."""
        rec_box = QtWidgets.QGroupBox("Record")
        rec = QtWidgets.QFormLayout(rec_box)
        self.open_button = QtWidgets.QPushButton("Open…")
        self.open_button.clicked.connect(self._ask_open)
        self.file_label = QtWidgets.QLabel("no file")
        self.file_label.setWordWrap(True)
        rec.addRow(self.open_button, self.file_label)
        self.fs_spin = QtWidgets.QDoubleSpinBox()
        self.fs_spin.setRange(0.0, 1e7)
        self.fs_spin.setDecimals(3)
        self.fs_spin.setSpecialValueText("from time column")
        self.fs_spin.setSuffix(" Hz")
        self.fs_spin.setValue(100.0)
        rec.addRow("Sampling frequency", self.fs_spin)
        self.input_combo = QtWidgets.QComboBox()
        self.input_combo.addItems(list(INPUT_KINDS))
        rec.addRow("Samples are", self.input_combo)
        self.units_combo = QtWidgets.QComboBox()
        self.units_combo.setEditable(True)
        self.units_combo.addItems(list(RECORD_UNITS))
        rec.addRow("Units", self.units_combo)
        self.scale_edit = QtWidgets.QLineEdit()
        self.scale_edit.setPlaceholderText("1 (counts → units)")
        rec.addRow("Scale", self.scale_edit)
        self.time_edit = QtWidgets.QLineEdit()
        self.time_edit.setPlaceholderText("none (index or name)")
        rec.addRow("Time column", self.time_edit)
        self.key_edit = QtWidgets.QLineEdit()
        self.key_edit.setPlaceholderText("only for .npz / HDF5 with several")
        rec.addRow("Array (key)", self.key_edit)
        self.points_spin = QtWidgets.QSpinBox()
        self.points_spin.setRange(2, 100000)
        self.points_spin.setValue(100)
        rec.addRow("Grid points", self.points_spin)
        self.compute_button = QtWidgets.QPushButton("Compute")
        self.compute_button.clicked.connect(self._guard(self.compute))
        rec.addRow(self.compute_button)
        return rec_box

    def _channel_box(self) -> QtWidgets.QGroupBox:
        """The channels to show (checkable list)."""
        ch_box = QtWidgets.QGroupBox("Channels")
        ch = QtWidgets.QVBoxLayout(ch_box)
        self.channel_list = QtWidgets.QListWidget()
        self.channel_list.setMaximumHeight(110)
        self.channel_list.itemChanged.connect(lambda _item: self._guard(self.redraw)())
        ch.addWidget(self.channel_list)
        return ch_box

    def _view_box(self) -> QtWidgets.QGroupBox:
        """Which view (Allan deviation, fit, ...) and the display unit."""
        view_box = QtWidgets.QGroupBox("View")
        view = QtWidgets.QFormLayout(view_box)
        self.view_buttons: dict[str, QtWidgets.QRadioButton] = {}
        row = QtWidgets.QHBoxLayout()
        group = QtWidgets.QButtonGroup(self)
        for name in VIEWS:
            button = QtWidgets.QRadioButton(name)
            group.addButton(button)
            row.addWidget(button)
            self.view_buttons[name] = button
            button.toggled.connect(self._view_toggled)
        self.view_buttons[VIEWS[0]].setChecked(True)
        view.addRow(row)
        self.display_combo = QtWidgets.QComboBox()
        self.display_combo.addItems(list(DISPLAY_UNITS))
        self.display_combo.currentTextChanged.connect(lambda _t: self._guard(self.redraw)())
        view.addRow("Show in", self.display_combo)
        return view_box

    def _diagnosis_box(self) -> QtWidgets.QGroupBox:
        """The noise-model file to diagnose the record against."""
        diag_box = QtWidgets.QGroupBox("Diagnosis against a model")
        diag = QtWidgets.QVBoxLayout(diag_box)
        self.model_button = QtWidgets.QPushButton("Model file…")
        self.model_button.clicked.connect(self._ask_model)
        self.model_label = QtWidgets.QLabel("no model")
        self.model_label.setWordWrap(True)
        diag.addWidget(self.model_button)
        diag.addWidget(self.model_label)
        return diag_box

    def _results_area(self) -> QtWidgets.QSplitter:
        """The plot above the table of the current view."""
        self.plot_area = QtWidgets.QWidget()
        self.plot_layout = QtWidgets.QVBoxLayout(self.plot_area)
        self.plot_layout.setContentsMargins(0, 0, 0, 0)
        self.table_title = QtWidgets.QLabel("")
        self.table_title.setStyleSheet("font-weight: bold; padding: 4px;")
        self.table = QtWidgets.QTableWidget(0, 0)
        self.table.setAlternatingRowColors(True)
        self.table.verticalHeader().setVisible(False)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        lower = QtWidgets.QWidget()
        lower_layout = QtWidgets.QVBoxLayout(lower)
        lower_layout.setContentsMargins(0, 0, 0, 0)
        lower_layout.addWidget(self.table_title)
        lower_layout.addWidget(self.table)
        split = QtWidgets.QSplitter(QtCore.Qt.Orientation.Vertical)
        split.addWidget(self.plot_area)
        split.addWidget(lower)
        split.setSizes([560, 240])
        return split

    def _build_menu(self) -> None:
        """File menu: the example record, open, export, quit."""
        menu = self.menuBar().addMenu("&File")
        example = menu.addAction("Open the &example record")
        example.triggered.connect(self._open_example)
        for text, slot, key in (
            ("&Open…", self._ask_open, QtGui.QKeySequence.StandardKey.Open),
            ("&Export report…", self._ask_export, QtGui.QKeySequence.StandardKey.Save),
            ("&Quit", self.close, QtGui.QKeySequence.StandardKey.Quit),
        ):
            action = menu.addAction(text)
            action.setShortcut(key)
            action.triggered.connect(slot)

    # --- helpers ------------------------------------------------------------------------------
    def _set_status(self, text: str, error: bool = False) -> None:
        self.status_label.setText(text)
        self.status_label.setStyleSheet("color: #b03a2e;" if error else "")

    def _guard(self, action: Any) -> Any:
        def run(*_args: Any) -> Any:
            try:
                return action()
            except _USER_ERRORS as exc:
                self._set_status(" ".join(str(exc).split()), error=True)
                return None
            except ImportError as exc:
                self._set_status(str(exc), error=True)
                return None
            except Exception as exc:  # a defect: shown in the window, not lost on stderr
                self._set_status(
                    f"unexpected error ({type(exc).__name__}: {' '.join(str(exc).split())[:300]});"
                    " please report it",
                    error=True,
                )
                return None

        return run

    def _empty_figure(self) -> Any:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(7, 5), layout="constrained")
        ax = fig.add_subplot()
        ax.text(
            0.5,
            0.5,
            "Open a record and press Compute",
            ha="center",
            va="center",
            fontsize=13,
            color="#7f8c8d",
            transform=ax.transAxes,
        )
        ax.set_axis_off()
        return fig

    def _show_figure(self, fig: Any) -> None:
        from matplotlib.backends.backend_qtagg import FigureCanvasQTAgg

        canvas = FigureCanvasQTAgg(fig)  # type: ignore[no-untyped-call]
        if self._canvas is not None:
            self.plot_layout.removeWidget(self._canvas)
            self._canvas.setParent(None)
            self._canvas.deleteLater()
        self._canvas = canvas
        self.plot_layout.addWidget(canvas)
        canvas.draw_idle()  # type: ignore[no-untyped-call]

    def _options_from_widgets(self) -> None:
        o = self.session.options
        o.fs = self.fs_spin.value() or None
        o.points = self.points_spin.value()
        o.input = self.input_combo.currentText()
        o.units = self.units_combo.currentText().strip() or None
        text = self.scale_edit.text().strip()
        try:
            o.scale = float(text) if text else None
        except ValueError as exc:
            raise ValueError(f"scale {text!r} is not a number") from exc
        o.time_column = self.time_edit.text().strip() or None
        o.key = self.key_edit.text().strip() or None

    def _fill_channels(self, names: tuple[str, ...]) -> None:
        self.channel_list.blockSignals(True)
        self.channel_list.clear()
        for name in names:
            item = QtWidgets.QListWidgetItem(name)
            item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(QtCore.Qt.CheckState.Checked)
            self.channel_list.addItem(item)
        self.channel_list.blockSignals(False)

    def _fill_table(self, title: str, header: list[str], rows: list[list[str]]) -> None:
        self.table_title.setText(title)
        self.table.clear()
        self.table.setColumnCount(len(header))
        self.table.setRowCount(len(rows))
        self.table.setHorizontalHeaderLabels(header)
        for r, row in enumerate(rows):
            for c, value in enumerate(row):
                item = QtWidgets.QTableWidgetItem(value)
                if _numeric(value):
                    item.setTextAlignment(
                        QtCore.Qt.AlignmentFlag.AlignRight | QtCore.Qt.AlignmentFlag.AlignVCenter
                    )
                self.table.setItem(r, c, item)
        self.table.resizeColumnsToContents()
        self.table.horizontalHeader().setStretchLastSection(False)

    # --- actions (public: used by the menu, the buttons and tests) -----------------------------
    def selected_channels(self) -> list[int]:
        """Return the indices of the checked channels."""
        return [
            k
            for k in range(self.channel_list.count())
            if self.channel_list.item(k).checkState() == QtCore.Qt.CheckState.Checked
        ]

    def current_view(self) -> str:
        """Name of the selected view."""
        return next(name for name, b in self.view_buttons.items() if b.isChecked())

    def open_file(self, path: str | Path) -> Record:
        """Load a record with the panel's options and compute its Allan deviation."""
        self._options_from_widgets()
        try:
            record = self.session.load(path)
        except BaseException:
            self._forget_record()  # the previous file is no longer the one shown as current
            raise
        if record.fs is not None and not self.session.options.fs:
            self.fs_spin.setValue(record.fs)
        self.file_label.setText(Path(path).name)
        self._fill_channels(record.channels)
        self.compute()
        return record

    def _forget_record(self) -> None:
        """No current record: a file that failed to load leaves nothing of the previous one."""
        self.session.use_record(None)
        self.file_label.setText("no file")
        self._fill_channels(())
        self._fill_table("", [], [])
        self._show_figure(self._empty_figure())

    def use_record(self, record: Record) -> None:
        """Show an already built record (e.g. the example)."""
        self.session.use_record(record)
        for field in (self.scale_edit, self.time_edit, self.key_edit):
            field.clear()  # reader options do not apply to a record given directly
        if record.fs is not None:
            self.fs_spin.setValue(record.fs)
        self.input_combo.setCurrentText(record.input)
        self.units_combo.setCurrentText(record.units or "")
        self.file_label.setText(Path(record.source).name)
        self._fill_channels(record.channels)
        self.compute()

    def compute(self) -> None:
        """Recompute with the panel's fs and number of grid points, then redraw."""
        self._options_from_widgets()
        if self.session.record is not None:
            o = self.session.options
            record = self.session.record
            if record.input != o.input or record.units != o.units:
                import dataclasses

                self.session.record = dataclasses.replace(record, input=o.input, units=o.units)
        result = self.session.compute()
        self._offer_display_units(result.units)
        self._info = (
            f"{self.session.summary_text()} — {result.tau.size} averaging times "
            f"({result.tau[0]:.3g} … {result.tau[-1]:.4g} s)"
        )
        self.redraw()

    def _offer_display_units(self, rate: str | None) -> None:
        """Offer only the display units of the record's sensor (gyro or accelerometer)."""
        wanted = list(display_units_for(rate))
        current = [self.display_combo.itemText(i) for i in range(self.display_combo.count())]
        if wanted == current:
            return
        keep = self.display_combo.currentText()
        self.display_combo.blockSignals(True)
        self.display_combo.clear()
        self.display_combo.addItems(wanted)
        self.display_combo.setCurrentText(keep if keep in wanted else wanted[0])
        self.display_combo.blockSignals(False)

    def set_view(self, name: str) -> None:
        """Switch to ``"Allan deviation"``, ``"Fit"`` or ``"Diagnosis"``."""
        if name not in VIEWS:
            raise ValueError(f"unknown view {name!r}; use one of {', '.join(VIEWS)}")
        self.view_buttons[name].setChecked(True)
        self.redraw()

    def _view_toggled(self, checked: bool) -> None:
        if checked:
            self._guard(self.redraw)()

    def redraw(self) -> None:
        """Draw the current view and fill the table."""
        if self.session.result is None:
            return
        view = self.current_view()
        if view == "Fit":
            self._draw_fit()
        elif view == "Diagnosis":
            self._draw_diagnosis()
        else:
            self._draw_adev()
        self._set_status(self._info)

    def _selected_or_raise(self) -> list[int]:
        chosen = self.selected_channels()
        if not chosen:
            raise ValueError("tick at least one channel")
        return chosen

    def _display(self) -> Any:
        return self.session.display_result(self.display_combo.currentText())

    def _draw_adev(self) -> None:
        from allanite.plot import allan_figure
        from allanite.slopes import slope_table

        chosen = self._selected_or_raise()
        result = self._display()
        names = self.session.channel_names()
        parts = [result.channel(c) for c in chosen]
        fig = allan_figure(
            parts,
            layout=None,
            labels=[names[c] for c in chosen],
            level=self.session.options.level,
            title=f"{self.file_label.text()} — Allan deviation",
        )
        self._show_figure(fig)
        rows = []
        for c in chosen:
            part = result.channel(c)
            for r in slope_table(part.tau, part.dev, part.edf):
                rows.append(
                    [
                        names[c],
                        r.term,
                        f"{r.tau_min:.3g} … {r.tau_max:.4g}",
                        r.label,
                        f"{r.slope:+.2f}",
                    ]
                )
        self._fill_table(
            "Slopes of the measured curve (dominant noise terms)",
            ["channel", "dominant term", "τ range [s]", "slope", "measured"],
            rows,
        )

    def _draw_fit(self) -> None:
        from allanite.plot import allan_figure, model_figure
        from allanite.report.coefficients import coefficient_table

        chosen = self._selected_or_raise()
        result = self._display()
        names = self.session.channel_names()
        rows = []
        first_fit = None
        for c in chosen:
            fit = self.session.fit(c)
            if fit is None:
                continue
            first_fit = first_fit if first_fit is not None else (c, fit)
            for k in coefficient_table(fit, result.units, self.session.options.level):
                interval = "–" if k.low != k.low else f"{k.low:.4g} … {k.high:.4g}"
                rows.append([names[c], k.term, k.symbol, f"{k.value:.4g}", interval, k.unit])
        if first_fit is None:
            fig = allan_figure(
                [result.channel(c) for c in chosen],
                labels=[names[c] for c in chosen],
                layout=None,
            )
            self._show_figure(fig)
            self._fill_table(
                "Noise coefficients", ["channel", "term", "symbol", "value", "interval", "unit"], []
            )
            raise ValueError("fitting is not available in this installation (allanite.fit)")
        c, fit = first_fit
        model = fit.model
        if result.units is not None and result.units != model.units["rate"]:
            model = model.in_units(result.units)  # the display unit of the data
        fig = model_figure(
            result,
            model,
            layout=None,
            channel=c,
            labels=list(names),
            level=self.session.options.level,
            title=f"{names[c]}: fitted noise model and its terms",
        )
        self._show_figure(fig)
        self._fill_table(
            "Noise coefficients in customary units (intervals: "
            f"{100 * self.session.options.level:.3g} %)" + _goodness_text(fit, names[c]),
            ["channel", "term", "symbol", "value", "interval", "unit"],
            rows,
        )

    def _draw_diagnosis(self) -> None:
        diagnosis = self.session.diagnosis
        if diagnosis is None:
            raise ValueError("choose a model file (Diagnosis against a model ▸ Model file…)")
        from allanite.plot.diagnosis import diagnosis_figure

        self._show_figure(diagnosis_figure(diagnosis))
        rows = [
            [
                a.effect,
                ", ".join(f"{k} = {v:.4g}" for k, v in a.params.items()),
                f"{100 * a.shrinkage:.0f} %",
                "yes" if a.consistent_after else "no",
            ]
            for a in diagnosis.attribution
        ]
        verdict = "significant gap" if diagnosis.significant else "no significant gap"
        self._fill_table(
            f"Diagnosis: {verdict} (p = {diagnosis.p_value:.3g})",
            ["effect", "parameters", "gap explained", "consistent after"],
            rows,
        )

    def load_model(self, path: str | Path) -> None:
        """Diagnose the first selected channel against a noise-model JSON file."""
        chosen = self._selected_or_raise()
        self.session.diagnose(path, chosen[0])
        self.model_label.setText(Path(path).name)
        self.set_view("Diagnosis")

    def export_report(self, path: str | Path) -> Path:
        """Write the HTML report of the selected channels."""
        if Path(path).suffix.lower() not in (".html", ".htm"):
            path = Path(path).with_suffix(".html")
        report = self.session.report_html(self.selected_channels())
        report.write(path)
        self._set_status(f"wrote {path}")
        return Path(path)

    def grab_screenshot(self, path: str | Path) -> Path:
        """Save a PNG of the window."""
        QtWidgets.QApplication.processEvents()
        if not self.grab().save(str(path), "PNG"):
            raise OSError(f"could not write the screenshot {path}")
        return Path(path)

    # --- dialogs ------------------------------------------------------------------------------
    def _ask_open(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Open record", "", _FILE_FILTER)
        if path:
            self._guard(lambda: self.open_file(path))()

    def _open_example(self) -> None:
        from allanite.examples import example_as_record

        self._guard(lambda: self.use_record(example_as_record()))()

    def _ask_model(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            self, "Noise model", "", "Noise model (*.json);;All files (*)"
        )
        if path:
            self._guard(lambda: self.load_model(path))()

    def _ask_export(self) -> None:
        path, _ = QtWidgets.QFileDialog.getSaveFileName(
            self, "Export report", "report.html", "HTML (*.html)"
        )
        if path:
            self._guard(lambda: self.export_report(path))()
