"""Simulator and estimator IMU noise configs: read them as noise models, write models back.

One module per format, each with ``NAME``, ``TITLE``, ``SUFFIXES``, ``sniff(text)``,
``read(text, rate=...) -> ImuConfig`` and ``write(config, rate=..., template=...,
tau_range=...) -> Written``; every reader maps the simulator's own discrete law exactly onto
:class:`~allanite.model.NoiseModel` Terms (each module's docstring names the
simulator source file its law was taken from), and every writer says what it dropped or projected
(:mod:`allanite.formats.projection`).

>>> from allanite.formats import read_config, write_config
>>> cfg = read_config("model.sdf", rate=250)          # doctest: +SKIP
>>> write_config(cfg, "imu.yaml").report()            # doctest: +SKIP
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

from allanite.errors import MissingExtraError
from allanite.formats import (
    airsim,
    allanite_json,
    gazebo_classic,
    gnss_ins_sim,
    gz_sdf,
    kalibr,
    matlab,
    openvins,
    orbslam3,
    px4_plugin,
    vins,
)
from allanite.formats.base import ImuConfig, Written
from allanite.formats.projection import Projection, project
from allanite.model import read_text_file

#: what a simulator config file is, for the messages of :func:`read_config`
CONFIG_TEXT = (
    "a simulator IMU config is text (YAML, SDF/XML, JSON, a MATLAB script) or an allanite "
    "model JSON"
)

__all__ = [
    "CONFIG_TEXT",
    "FORMATS",
    "ImuConfig",
    "Projection",
    "Written",
    "detect_format",
    "format_module",
    "project",
    "read_config",
    "write_config",
]

#: format name -> module, in the order content sniffing tries them
FORMATS: dict[str, ModuleType] = {
    m.NAME: m
    for m in (
        allanite_json,
        px4_plugin,
        gz_sdf,
        openvins,
        kalibr,
        orbslam3,
        vins,
        airsim,
        matlab,
        gnss_ins_sim,
        gazebo_classic,
    )
}

#: format of a file written without a template or --to, by suffix, where several share it
SUFFIX_DEFAULTS = {
    ".json": "allanite",
    ".sdf": "gz-sdf",
    ".world": "gz-sdf",
    ".yaml": "kalibr",
    ".yml": "kalibr",
}


def format_module(name: str) -> ModuleType:
    """The module of a format name, or a ValueError listing the names."""
    if name not in FORMATS:
        raise ValueError(f"unknown config format {name!r}; use one of {', '.join(FORMATS)}")
    return FORMATS[name]


def detect_format(path: str | Path, text: str | None = None) -> str:
    """Format of a config from its content (and suffix); ``text`` is read when omitted.

    Without ``text`` (a file to write), a suffix several formats share gives the format of
    :data:`SUFFIX_DEFAULTS` (``.json`` model JSON, ``.sdf`` gz-sensors, ``.yaml`` Kalibr).

    Raises
    ------
    ValueError
        When neither the content nor the suffix identifies one format.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if text is not None:
        by_suffix = [n for n, m in FORMATS.items() if suffix in m.SUFFIXES]
        for name in by_suffix or list(FORMATS):
            if FORMATS[name].sniff(text):
                return name
        for name, module in FORMATS.items():
            if module.sniff(text):
                return name
    elif suffix:
        candidates = [n for n, m in FORMATS.items() if suffix in m.SUFFIXES]
        if len(candidates) == 1:
            return candidates[0]
        if suffix in SUFFIX_DEFAULTS:
            return SUFFIX_DEFAULTS[suffix]
    raise ValueError(
        f"{path}: cannot tell which simulator config this is; give it with format=NAME "
        f"(CLI: --sim-format NAME; model convert: --from NAME or --to NAME), NAME one of "
        f"{', '.join(FORMATS)}"
    )


def read_config(
    path: str | Path, *, format: str | None = None, rate: float | None = None
) -> ImuConfig:
    """Read a simulator/estimator IMU config (format from content and suffix unless given)."""
    path = Path(path)
    text = read_text_file(path, CONFIG_TEXT)
    name = format or detect_format(path, text)
    try:
        config: ImuConfig = format_module(name).read(text, rate=rate)
    except ValueError as exc:
        raise ValueError(f"{path} ({name}): {exc}") from None
    return config


def _template_rate(module: ModuleType, text: str) -> float | None:
    """The IMU rate a template states (``update_rate``, ``<update_rate>``...), or None."""
    try:
        rate: float | None = module.read(text).rate
    except ValueError:  # a template the reader cannot take as a whole states no rate we use
        return None
    return rate


def write_config(
    config: ImuConfig,
    path: str | Path,
    *,
    format: str | None = None,
    rate: float | None = None,
    template: str | Path | None = None,
    tau_range: tuple[float, float] | None = None,
    read_back: bool = False,
) -> Written:
    """Write ``config`` to ``path`` atomically; return what was written, dropped, projected.

    The format is ``format``, else the template's content, else the suffix of ``path`` (the
    config's own format when it shares the suffix). With ``read_back`` the text is first read
    with the format's reader, so a reader's missing extra (pyyaml for the YAML formats) is
    raised before anything is written, not after (``allanite model convert`` reads every
    file it writes back to check it).
    """
    from allanite.io.atomic import atomic_output

    path = Path(path)
    template_text = Path(template).read_text(encoding="utf-8") if template is not None else None
    if format is None:
        if template is not None:
            format = detect_format(Path(template), template_text)
        else:
            suffix = path.suffix.lower()
            candidates = [n for n, m in FORMATS.items() if suffix in m.SUFFIXES]
            if config.source_format in candidates:
                format = config.source_format  # e.g. .yaml -> .yaml keeps the format
            else:
                format = detect_format(path)
    module = format_module(format)
    if rate is None and config.rate is None and template_text is not None:
        rate = _template_rate(module, template_text)
    written: Written = module.write(config, rate=rate, template=template_text, tau_range=tau_range)
    if read_back:
        try:
            module.read(written.text, rate=rate)
        except MissingExtraError as exc:
            raise MissingExtraError(
                f"{path} was not written: checking it means reading it back, and {exc}",
                extra=exc.extra,
            ) from None
    with atomic_output(path) as tmp:
        Path(tmp).write_text(written.text, encoding="utf-8")
    return written
