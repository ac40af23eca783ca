r"""gz-sensors (Gazebo) SDF ``<imu>`` noise blocks, per axis, gyro and accelerometer.

``<sensor type="imu"><update_rate>`` and, for each axis of ``<angular_velocity>`` and
``<linear_acceleration>``, ``<noise type="gaussian">`` with (SI units):

=============================  ===============================================================
element                        discrete law (``src/GaussianNoiseModel.cc``, ``ImuSensor.cc``)
=============================  ===============================================================
stddev                         white per-sample std: White ``N = stddev sqrt(dt)``
mean                           constant offset (no Allan variance; kept in ``offsets``)
bias_mean, bias_stddev         bias drawn once from N(bias_mean, bias_stddev), sign flipped with
                               probability 1/2: zero mean, variance ``bias_mean^2 +
                               bias_stddev^2``: TurnOnBias ``sigma = hypot(mean, stddev)``
dynamic_bias_stddev ``s_b``,   exact first-order Gauss-Markov, ``phi = exp(-dt/T)``, driving
dynamic_bias_correlation_time  std ``s_b sqrt(T/2 (1 - phi^2))``: GaussMarkov ``sigma =
``T``                          s_b sqrt(T/2)``, ``tau_c = T`` (``s_b`` is a driving density)
precision ``p``                output rounded to multiples of ``p``: a white error of variance
                               ``p^2/12`` (Sheppard; exact enough while ``p < 2 stddev``),
                               folded into White ``N = sqrt(stddev^2 + p^2/12) sqrt(dt)``
=============================  ===============================================================

Gazebo classic implements the same names without the dynamic bias.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

from allanite.formats import _xml_edit
from allanite.formats._text import number_text
from allanite.formats.base import (
    ImuConfig,
    Written,
    need_rate,
    notes_of_others,
    number,
    sensor_model,
)
from allanite.formats.projection import project_config
from allanite.model import NoiseModel
from allanite.terms import GaussMarkov, Term, TurnOnBias, White

NAME = "gz-sdf"
TITLE = "gz-sensors SDF <imu> noise"

#: unit of each noise element (gyro | accelerometer), as gz-sensors applies it per sample
UNITS = {
    "dynamic_bias_correlation_time": "s",
    "dynamic_bias_stddev": "rad/s/sqrt(s) | m/s^2/sqrt(s), a driving density",
    "bias_stddev": "rad/s | m/s^2",
    "bias_mean": "rad/s | m/s^2",
    "stddev": "per sample: rad/s | m/s^2",
    "mean": "rad/s | m/s^2",
    "precision": "rad/s | m/s^2",
}
SUFFIXES = (".sdf", ".world", ".xml", ".urdf", ".xacro")
HOLDS = frozenset({"white", "turn_on_bias", "markov"})
BLOCKS = {"gyro": "angular_velocity", "accel": "linear_acceleration"}
AXES = ("x", "y", "z")
FIELDS = (
    "mean",
    "stddev",
    "bias_mean",
    "bias_stddev",
    "dynamic_bias_stddev",
    "dynamic_bias_correlation_time",
    "precision",
)


def sniff(text: str) -> bool:
    """An ``<imu>`` element with ``angular_velocity``/``linear_acceleration`` noise."""
    return "<imu" in text and ("<angular_velocity" in text or "<linear_acceleration" in text)


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _parse(text: str) -> ET.Element:
    try:
        return ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    except ET.ParseError as exc:
        raise ValueError(f"SDF is not valid XML: {exc}") from None


def _find(root: ET.Element, name: str) -> ET.Element | None:
    for el in root.iter():
        if isinstance(el.tag, str) and _local(el.tag) == name:
            return el
    return None


def _child(el: ET.Element, name: str) -> ET.Element | None:
    for c in el:
        if isinstance(c.tag, str) and _local(c.tag) == name:
            return c
    return None


def _disabled(noise: ET.Element | None) -> bool:
    """Whether a ``<noise>`` element is switched off (``type="none"``: its entries unused)."""
    return noise is not None and noise.get("type", "gaussian").lower() == "none"


def _axis_values(noise: ET.Element | None, where: str) -> dict[str, float]:
    if noise is None or _disabled(noise):
        return {}
    out = {}
    for name in FIELDS:
        el = _child(noise, name)
        text = (el.text or "").strip() if el is not None else ""
        if text:
            out[name] = number(text, f"{where} <{name}>") if name != "mean" else float(text)
    return out


def terms_from_values(values: dict[str, float], dt: float | None, where: str) -> list[Term]:
    """The Terms of one axis' noise values under gz-sensors' law (see the module docstring)."""
    terms: list[Term] = []
    std, prec = values.get("stddev", 0.0), values.get("precision", 0.0)
    if std > 0 or prec > 0:
        step = 1.0 / need_rate(None if dt is None else 1.0 / dt, f"{where} <stddev>")
        terms.append(White(N=math.sqrt(std**2 + prec**2 / 12.0) * math.sqrt(step)))
    on = math.hypot(values.get("bias_mean", 0.0), values.get("bias_stddev", 0.0))
    if on > 0:
        terms.append(TurnOnBias(sigma=on))
    s_b = values.get("dynamic_bias_stddev", 0.0)
    tc = values.get("dynamic_bias_correlation_time", 0.0)
    if s_b > 0 and tc > 0:
        terms.append(GaussMarkov(sigma=s_b * math.sqrt(tc / 2.0), tau_c=tc))
    return terms


def read(text: str, *, rate: float | None = None, axis: str = "x") -> ImuConfig:
    """Read the noise of every axis; the model is ``axis``'s (differences are noted)."""
    root = _parse(text)
    imu = root if _local(root.tag) == "imu" else _find(root, "imu")
    if imu is None:
        raise ValueError("SDF: no <imu> element with noise blocks found")
    notes: list[str] = []
    update = _find(root, "update_rate")
    update_text = (update.text or "").strip() if update is not None else ""
    if update_text:
        found = number(update_text, "SDF <update_rate>")
        if rate is None and found > 0:
            rate = found
        elif rate is not None and found > 0 and abs(found - rate) > 1e-9 * rate:
            notes.append(f"<update_rate> {found:g} Hz overridden by the given rate {rate:g} Hz")
    dt = 1.0 / rate if rate else None
    models: dict[str, NoiseModel] = {}
    offsets: dict[str, float] = {}
    for sensor, block_name in BLOCKS.items():
        block = _child(imu, block_name)
        if block is None:
            continue
        per_axis = {
            a: _axis_values(
                _child(_child(block, a) or ET.Element("none"), "noise"), f"SDF {block_name}/{a}"
            )
            for a in AXES
        }
        if axis not in per_axis:
            raise ValueError(f"axis must be one of x, y, z, got {axis!r}")
        chosen = per_axis[axis]
        off = [
            a for a in AXES if _disabled(_child(_child(block, a) or ET.Element("none"), "noise"))
        ]
        if off:
            notes.append(
                f'{sensor}: <noise type="none"> on axis {", ".join(off)}: gz-sensors adds no '
                'noise there and ignores its entries; set type="gaussian" to use them'
            )
        differ = [a for a in AXES if per_axis[a] != chosen]
        if differ:
            notes.append(
                f"{sensor}: axes {', '.join(differ)} differ from {axis}; the model is {axis}'s"
            )
        terms = terms_from_values(chosen, dt, f"SDF {block_name}/{axis}")
        models[sensor] = sensor_model(terms, sensor)
        if chosen.get("mean"):
            offsets[sensor] = chosen["mean"]
    if not models:
        raise ValueError("SDF: the <imu> element has no angular_velocity/linear_acceleration")
    topic = _find(root, "topic")
    return ImuConfig(
        gyro=models.get("gyro"),
        accel=models.get("accel"),
        rate=rate,
        offsets=offsets,
        source_format=NAME,
        notes=tuple(notes),
        topic=(topic.text or "").strip() if topic is not None else "",
    )


def _safe(text: str) -> str:
    """Text that may stand inside an XML comment (no ``--``)."""
    return text.replace("--", "- -")


def _set(parent: ET.Element, name: str, value: str) -> None:
    el = _child(parent, name)
    if el is None:
        el = ET.SubElement(parent, name)
    el.text = value


def values_from_model(
    model: NoiseModel, dt: float, precision: float = 0.0
) -> tuple[dict[str, float], list[str]]:
    """Noise element values of a model holding white, turn-on and Gauss-Markov terms."""
    out: dict[str, float] = {}
    notes: list[str] = []
    white = model.terms_of_type("white")
    var = white[0].values()["N"] ** 2 / dt if white else 0.0
    if precision > 0:
        rest = var - precision**2 / 12.0
        if rest < 0:
            notes.append(f"precision {precision:g} exceeds the white noise; precision removed")
            precision = 0.0
        else:
            var = rest
            out["precision"] = precision
    out["stddev"] = math.sqrt(var)
    on = model.terms_of_type("turn_on_bias")
    out["bias_mean"] = 0.0
    out["bias_stddev"] = on[0].values()["sigma"] if on else 0.0
    gm = model.terms_of_type("markov")
    if gm:
        sigma, tc = gm[0].values()["sigma"], gm[0].values()["tau_c"]
        out["dynamic_bias_stddev"] = sigma * math.sqrt(2.0 / tc)
        out["dynamic_bias_correlation_time"] = tc
    else:
        out["dynamic_bias_stddev"] = 0.0
        out["dynamic_bias_correlation_time"] = 0.0
    return out, notes


def _set_noise(
    noise: ET.Element, model: NoiseModel, dt: float, offset: float | None, *, fresh: bool
) -> list[str]:
    """Set one axis' ``<noise>`` element to ``model``; what it could not hold.

    Values the element states as the model has them are left as the user wrote them (a
    turn-on bias split into ``bias_mean`` and ``bias_stddev`` keeps its split, an entry left
    out, which gz-sensors reads as zero, is not added as a zero).
    """
    if noise.get("type", "").lower() == "none":
        noise.set("type", "gaussian")
    prec_el = _child(noise, "precision")
    prec = float(prec_el.text) if prec_el is not None and prec_el.text else 0.0
    was = _axis_values(noise, "SDF template")
    values, notes = values_from_model(model, dt, prec)
    on = math.hypot(was.get("bias_mean", 0.0), was.get("bias_stddev", 0.0))
    if math.isclose(on, values["bias_stddev"], rel_tol=1e-9, abs_tol=0.0):
        del values["bias_mean"], values["bias_stddev"]  # the user's split is kept
    if "precision" not in values and prec_el is not None:
        noise.remove(prec_el)
    if offset is not None:
        values["mean"] = offset
    elif _child(noise, "mean") is None:
        values["mean"] = 0.0
    for name in FIELDS:
        if name not in values or (not fresh and values[name] == 0 and _child(noise, name) is None):
            continue
        _set(noise, name, number_text(values[name]))
    return notes


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
    holds: frozenset[str] = HOLDS,
) -> Written:
    """The ``<sensor type="imu">`` element (or ``template`` with its noise blocks replaced)."""
    rate = need_rate(rate or config.rate, "gz-sensors <stddev>")
    dt = 1.0 / rate
    models, dropped, projections = project_config(config, holds, rate=rate, tau_range=tau_range)
    spans = None
    if template is not None:
        root, spans = _xml_edit.parse(template)
        imu = root if _local(root.tag) == "imu" else _find(root, "imu")
        if imu is None:
            raise ValueError("SDF template: no <imu> element to write the noise into")
    else:
        root = ET.Element("sensor", {"name": "imu_sensor", "type": "imu"})
        ET.SubElement(root, "always_on").text = "1"
        ET.SubElement(root, "update_rate").text = number_text(rate)
        imu = ET.SubElement(root, "imu")
    update = _find(root, "update_rate")
    if update is not None:
        update.text = number_text(rate)
    for sensor, model in models.items():
        block = _child(imu, BLOCKS[sensor])
        if block is None:
            block = ET.SubElement(imu, BLOCKS[sensor])
        for a in AXES:
            if config.axes and a not in config.axes and template is not None:
                continue  # an axis the model does not describe keeps the template's values
            axis_el = _child(block, a)
            if axis_el is None:
                axis_el = ET.SubElement(block, a)
            noise = _child(axis_el, "noise")
            fresh = noise is None
            if noise is None:
                noise = ET.SubElement(axis_el, "noise", {"type": "gaussian"})
            notes = _set_noise(noise, model, dt, config.offsets.get(sensor), fresh=fresh)
            dropped.extend(f"{sensor}/{a}: {n}" for n in notes)
    comments = [f"<!-- dropped: {_safe(d)} -->" for d in dropped]
    comments += [f"<!-- projected: {_safe(p)} -->" for p in projections]
    if template is not None and spans is not None:  # the user's text, edited in place
        return Written(_in_place(template, root, spans, comments, config), dropped, projections)
    ET.indent(root, space="  ")
    text = ET.tostring(root, encoding="unicode")
    head = ""
    if template is not None and template.lstrip().startswith("<?xml"):
        head = template.lstrip().split("?>", 1)[0] + "?>\n"
    if template is not None:  # the notes of an earlier write on the sensor this one leaves
        earlier = re.findall(r"<!--(.*?)-->", template.split("<" + _local(root.tag), 1)[0], re.S)
        comments += [f"<!-- {n} -->" for n in notes_of_others(earlier, config.sensors)]
    return Written(head + "\n".join([*comments, text]) + "\n", dropped, projections)


#: a note of an earlier write before the root element, with its line
_EARLIER = re.compile(r"[ \t]*<!-- (?:dropped|projected): (gyro|accel)\b.*?-->[ \t]*\n?", re.S)


def _in_place(
    template: str, root: ET.Element, spans: _xml_edit.Spans, notes: list[str], config: ImuConfig
) -> str:
    """``template`` with the tree's edits made in place and this write's notes before the root.

    The earlier notes on the sensors this write sets are replaced; the other sensor's stay.
    """
    text = _xml_edit.serialize(root, spans)
    start = spans.spans[id(root)].start
    cut = len(spans.data[:start].decode("utf-8"))
    head = _EARLIER.sub(lambda m: "" if m.group(1) in config.sensors else m.group(0), text[:cut])
    block = "".join(f"{n}\n" for n in notes)
    return head + block + text[cut:]
