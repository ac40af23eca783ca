"""How to read a record: one options object shared by :func:`read_record`, the CLI and the GUI."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["Column", "ReadOptions"]

Column = int | str

#: the options that describe the table itself (those of :func:`allanite.io.make_record`)
TABLE_FIELDS = (
    "fs",
    "input",
    "units",
    "columns",
    "time_column",
    "time_scale",
    "gaps",
    "scale",
    "fs_source",
    "temperature",
)


@dataclass(frozen=True)
class ReadOptions:
    """Everything :func:`allanite.io.read_record` needs to know beyond the file itself.

    The CLI's reader flags build one (``allanite.cli.record_options.read_options``), the GUI
    another; :func:`allanite.io.read_record` takes one, or the same fields as keywords.

    Attributes
    ----------
    fs : float, optional
        Sampling frequency in Hz (inferred from ``time_column`` when omitted).
    input : {"rate", "increment", "angle"}
        What the samples are.
    units : str, optional
        Unit of the samples after ``scale`` (e.g. ``"deg/s"``).
    columns : int, str or sequence, optional
        Channels by 0-based index or name (header names, Parquet/DataFrame columns).
    time_column : int or str, optional
        Column of time stamps (seconds times ``time_scale``).
    time_scale : float
        Seconds per time-stamp unit.
    gaps : {"error", "split", "fill"}
        What to do about gaps in the time column.
    scale : float, optional
        Counts-to-units factor.
    fs_source : {"time", "fs"}, optional
        Which rate wins when ``fs`` and the time column disagree by more than
        :data:`allanite.io.timebase.FS_CONFLICT`: the time stamps or the given ``fs``.
        Without it such a record is refused.
    format : {"text", "npy", "npz", "raw", "hdf5", "parquet"}, optional
        Override the suffix-based detection. Any raw-layout option (``dtype``,
        ``n_channels``, ``byteorder``, ``offset``) means raw binary whatever the suffix,
        except a self-describing one (.npy, .npz, HDF5, Parquet), which is refused.
    delimiter : str, optional
        Text field separator (detected when omitted).
    header : bool, optional
        Whether a text file starts with column names (detected when omitted).
    key : str, optional
        Array in an .npz archive or dataset path in an HDF5 file.
    dtype, n_channels, byteorder, offset
        Raw binary layout: sample type, interleaved channels (default 1),
        ``"little"`` (default), ``"big"`` or ``"native"``, bytes to skip at the start
        (default 0).
    topic : str, optional
        ROS bag IMU topic, or ULog topic (``sensor_combined``, ``sensor_gyro[:instance]``,
        ``sensor_accel``); see :mod:`allanite.io.robot_logs`.
    temperature : int or str, optional
        The sensor temperature in °C: a column (text, Parquet, DataFrame), an HDF5 dataset or
        netCDF variable, a ROS ``sensor_msgs/Temperature`` topic, or the ``temperature`` field
        of a ULog ``sensor_gyro``/``sensor_accel`` topic; resampled onto the sample times
        (:attr:`allanite.io.Record.temperature`).
    """

    fs: float | None = None
    input: str = "rate"
    units: str | None = None
    columns: Column | Sequence[Column] | None = None
    time_column: Column | None = None
    time_scale: float = 1.0
    gaps: str = "error"
    scale: float | None = None
    fs_source: str | None = None
    format: str | None = None
    delimiter: str | None = None
    header: bool | None = None
    key: str | None = None
    dtype: str | None = None
    n_channels: int | None = None
    byteorder: str | None = None
    offset: int | None = None
    topic: str | None = None
    temperature: Column | None = None

    def replace(self, **changes: Any) -> ReadOptions:
        """A copy with some fields changed; an unknown name is a TypeError listing the fields."""
        names = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise TypeError(
                f"unknown reader option(s) {', '.join(unknown)}; the options are "
                f"{', '.join(sorted(names))}"
            )
        return dataclasses.replace(self, **changes) if changes else self

    def table(self) -> dict[str, Any]:
        """The options that describe the table (keywords of :func:`allanite.io.make_record`)."""
        return {name: getattr(self, name) for name in TABLE_FIELDS}

    def raw_layout(self) -> dict[str, Any]:
        """The raw-binary layout options that were given (not None)."""
        layout = {
            "dtype": self.dtype,
            "n_channels": self.n_channels,
            "byteorder": self.byteorder,
            "offset": self.offset,
        }
        return {name: value for name, value in layout.items() if value is not None}

    def as_dict(self) -> dict[str, Any]:
        """Every field by name (keywords of :func:`allanite.io.read_record`)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
