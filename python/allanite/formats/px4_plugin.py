r"""PX4 / RotorS Gazebo-classic IMU plugin parameters (``libgazebo_imu_plugin.so``).

``gyroscopeNoiseDensity`` (rad/s/sqrt(Hz)), ``gyroscopeRandomWalk`` (rad/s^2/sqrt(Hz)),
``gyroscopeBiasCorrelationTime`` (s), ``gyroscopeTurnOnBiasSigma`` (rad/s), and the
``accelerometer*`` parameters alike (m/s^2 based). The discrete law
(``src/gazebo_imu_plugin.cpp``): white std ``density / sqrt(dt)``; bias
``b[k] = phi b[k-1] + sigma_b sqrt(T/2 (1 - phi^2)) w[k]``, ``phi = exp(-dt/T)``, from 0;
turn-on bias drawn once from N(0, sigma_on). Hence, at any rate, White ``N = density``,
GaussMarkov ``sigma = random_walk sqrt(T/2)``, ``tau_c = T`` (the bias starts at 0 rather than
in its stationary law, a transient of length ~T), TurnOnBias ``sigma = sigma_on``.
Parameters missing from the SDF take the plugin's defaults (ADIS16448 values of
``include/gazebo_imu_plugin.h``), as the simulator does.
"""

from __future__ import annotations

import math
import re

from allanite.formats._text import keep_number, number_text
from allanite.formats.base import ImuConfig, Written, number, sensor_model
from allanite.formats.projection import project_config
from allanite.model import NoiseModel
from allanite.terms import GaussMarkov, Term, TurnOnBias, White

NAME = "px4-plugin"
TITLE = "PX4/RotorS Gazebo IMU plugin"
SUFFIXES = (".sdf", ".xacro", ".urdf", ".world", ".xml", ".jinja")
HOLDS = frozenset({"white", "markov", "turn_on_bias"})
PREFIX = {"gyro": "gyroscope", "accel": "accelerometer"}
SUFFIX = ("NoiseDensity", "RandomWalk", "BiasCorrelationTime", "TurnOnBiasSigma")
#: the plugin's defaults (ADIS16448), include/gazebo_imu_plugin.h
DEFAULTS = {
    "gyroscopeNoiseDensity": 2.0 * 35.0 / 3600.0 / 180.0 * math.pi,
    "gyroscopeRandomWalk": 2.0 * 4.0 / 3600.0 / 180.0 * math.pi,
    "gyroscopeBiasCorrelationTime": 1.0e3,
    "gyroscopeTurnOnBiasSigma": 0.5 / 180.0 * math.pi,
    "accelerometerNoiseDensity": 2.0 * 2.0e-3,
    "accelerometerRandomWalk": 2.0 * 3.0e-3,
    "accelerometerBiasCorrelationTime": 300.0,
    "accelerometerTurnOnBiasSigma": 20.0e-3 * 9.8,  # the header's literal 9.8
}

#: unit of each parameter (the plugin's header comments)
UNITS = {
    "gyroscopeNoiseDensity": "rad/s/sqrt(Hz)",
    "gyroscopeRandomWalk": "rad/s^2/sqrt(Hz)",
    "gyroscopeBiasCorrelationTime": "s",
    "gyroscopeTurnOnBiasSigma": "rad/s",
    "accelerometerNoiseDensity": "m/s^2/sqrt(Hz)",
    "accelerometerRandomWalk": "m/s^3/sqrt(Hz)",
    "accelerometerBiasCorrelationTime": "s",
    "accelerometerTurnOnBiasSigma": "m/s^2",
}


def sniff(text: str) -> bool:
    """The plugin's parameter names."""
    return "gyroscopeNoiseDensity" in text or "libgazebo_imu_plugin" in text


def _element(name: str) -> re.Pattern[str]:
    """``<name>text</name>`` with no tag inside; linear time (no nested quantifiers)."""
    return re.compile(rf"<{name}>([^<]*)</{name}>")


def _with_value(match: re.Match[str], value: str) -> str:
    """The matched element with its text replaced by ``value`` (its spacing kept).

    The same number keeps the user's spelling (:func:`keep_number`: ``0.0`` stays ``0.0``).
    """
    inner = match.group(1)
    body = inner.strip()
    lead = inner[: len(inner) - len(inner.lstrip())]
    trail = inner[len(inner.rstrip()) :] if body else ""
    name = match.re.pattern[1 : match.re.pattern.index(">")]
    return f"<{name}>{lead}{keep_number(body, value)}{trail}</{name}>"


def terms_from_parameters(values: dict[str, float], sensor: str) -> list[Term]:
    """The Terms of one sensor's plugin parameters (see the module docstring)."""
    p = PREFIX[sensor]
    terms: list[Term] = []
    density, walk = values[p + "NoiseDensity"], values[p + "RandomWalk"]
    tc, on = values[p + "BiasCorrelationTime"], values[p + "TurnOnBiasSigma"]
    if density > 0:
        terms.append(White(N=density))
    if walk > 0:
        if not tc > 0:
            raise ValueError(f"{p}BiasCorrelationTime must be positive, got {tc!r}")
        terms.append(GaussMarkov(sigma=walk * math.sqrt(tc / 2.0), tau_c=tc))
    if on > 0:
        terms.append(TurnOnBias(sigma=on))
    return terms


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the plugin parameters (missing ones take the plugin's defaults, noted)."""
    values: dict[str, float] = {}
    defaulted = []
    for key, default in DEFAULTS.items():
        match = _element(key).search(text)
        if match:
            values[key] = number(match.group(1).strip(), f"IMU plugin <{key}>")
        else:
            values[key] = default
            defaulted.append(key)
    notes = (f"plugin defaults used for {', '.join(defaulted)}",) if defaulted else ()
    return ImuConfig(
        gyro=sensor_model(terms_from_parameters(values, "gyro"), "gyro"),
        accel=sensor_model(terms_from_parameters(values, "accel"), "accel"),
        rate=rate,
        source_format=NAME,
        notes=notes,
    )


def parameters_from_model(model: NoiseModel, sensor: str, tc_default: float) -> dict[str, float]:
    """Plugin parameters of a model holding white, one Gauss-Markov and a turn-on bias."""
    p = PREFIX[sensor]
    white = model.terms_of_type("white")
    gm = model.terms_of_type("markov")
    on = model.terms_of_type("turn_on_bias")
    out = {p + "NoiseDensity": white[0].values()["N"] if white else 0.0}
    if gm:
        sigma, tc = gm[0].values()["sigma"], gm[0].values()["tau_c"]
        out[p + "RandomWalk"] = sigma * math.sqrt(2.0 / tc)
        out[p + "BiasCorrelationTime"] = tc
    else:
        out[p + "RandomWalk"] = 0.0
        out[p + "BiasCorrelationTime"] = tc_default
    out[p + "TurnOnBiasSigma"] = on[0].values()["sigma"] if on else 0.0
    return out


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """The plugin element (or ``template`` with the parameter values replaced)."""
    rate = rate or config.rate
    models, dropped, projections = project_config(config, HOLDS, rate=rate, tau_range=tau_range)
    values: dict[str, float] = {}
    for sensor, model in models.items():
        values.update(
            parameters_from_model(model, sensor, DEFAULTS[PREFIX[sensor] + "BiasCorrelationTime"])
        )
    notes = [f"<!-- dropped: {d.replace('--', '- -')} -->" for d in dropped]
    notes += [f"<!-- projected: {p.replace('--', '- -')} -->" for p in projections]
    if template is not None:
        text = template
        for key, value in values.items():
            pattern = _element(key)
            if pattern.search(text):
                new = number_text(value)
                text = pattern.sub(lambda m, v=new: _with_value(m, v), text)  # type: ignore[misc]
            else:
                text = _insert_element(text, key, number_text(value))
        return Written(_with_notes(text, notes, config.sensors), dropped, projections)
    lines = [*notes, '<plugin name="imu_plugin" filename="libgazebo_imu_plugin.so">']
    lines += ["  <linkName>imu_link</linkName>", "  <imuTopic>/imu</imuTopic>"]
    lines += [f"  <{k}>{number_text(v)}</{k}>" for k, v in values.items()]
    lines.append("</plugin>")
    return Written("\n".join(lines) + "\n", dropped, projections)


#: the closing tag, with its indentation when it starts a line (group 1 None: inline)
_PLUGIN_END = re.compile(r"(^[ \t]*)?</plugin>", re.M)
_FIRST_CHILD = re.compile(r"<plugin\b[^>]*imu_plugin[^>]*>\s*?\n([ \t]*)<")


def _insert_element(text: str, key: str, value: str) -> str:
    """``text`` with ``<key>value</key>`` added as the last element of the IMU plugin block.

    A template without a parameter (the plugin then takes its default, as
    :func:`read` does) gets it written, as the plugin reads it; the element goes before the
    ``</plugin>`` that closes the IMU plugin, indented like the block's first element.
    """
    start = _PLUGIN.search(text)
    end = _PLUGIN_END.search(text, start.end()) if start is not None else None
    if start is None or end is None:
        raise ValueError(
            f"the template has no <{key}> element and no IMU plugin block "
            '(<plugin ... filename="libgazebo_imu_plugin.so"> ... </plugin>) to add it to; add '
            "it by hand or write without a template"
        )
    element = f"<{key}>{value}</{key}>"
    if end.group(1) is None:  # a one-line block, <plugin ...></plugin>: the element goes inline
        at = end.start()
        return text[:at] + element + text[at:]
    child = _FIRST_CHILD.search(text, start.start())
    inside = child is not None and child.end() < end.start()
    indent = child.group(1) if child is not None and inside else end.group(1) + "  "
    return text[: end.start()] + f"{indent}{element}\n" + text[end.start() :]


_NOTE = re.compile(r"[ \t]*<!-- (dropped|projected): (\w+).*? -->\n?")
#: the IMU plugin's opening tag, with its indentation when it starts a line
_PLUGIN = re.compile(r"(^[ \t]*)?<plugin\b[^>]*imu_plugin", re.M)


def _with_notes(text: str, notes: list[str], sensors: tuple[str, ...]) -> str:
    """A template with this write's notes before its plugin element.

    The earlier notes of the ``sensors`` this write sets are replaced; the other sensor's
    entries stay as the template had them, and so do its notes.
    """
    text = _NOTE.sub(lambda m: "" if m.group(2) in sensors else m.group(0), text)
    if not notes:
        return text
    found = _PLUGIN.search(text)
    if found is None:
        return text.rstrip("\n") + "\n" + "\n".join(notes) + "\n"
    indent = found.group(1) or ""
    block = "".join(f"{indent}{n}\n" for n in notes)
    return text[: found.start()] + block + text[found.start() :]
