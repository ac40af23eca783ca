r"""gnss-ins-sim IMU error dictionary (``imu_model.IMU(accuracy=imu_err)``).

Keys and units (``gnss_ins_sim/sim/imu_model.py``): ``gyro_b`` (deg/h, constant),
``gyro_arw`` (deg/sqrt(h)), ``gyro_b_stability`` (deg/h), ``gyro_b_corr`` (s), ``accel_b``
(m/s^2), ``accel_vrw`` (m/s/sqrt(h)), ``accel_b_stability`` (m/s^2), ``accel_b_corr`` (s).
The discrete law (``pathgen.bias_drift``, ``gyro_gen``): white std ``arw / sqrt(dt)``; with a
finite correlation time ``T`` the drift is ``x[k] = (1 - dt/T) x[k-1] + s sqrt(1 -
exp(-2 dt/T)) w[k]`` from 0 (note ``1 - dt/T``, not ``exp(-dt/T)``): GaussMarkov from that
AR(1) exactly (``phi = 1 - dt/T``); with ``T = inf`` the drift is *white* per-sample noise of
std ``s`` (not a random walk), folded into White ``N = sqrt(arw^2 + s^2 dt)``. Read from a
Python file: the dict literal holding ``gyro_arw`` (numbers, lists, ``np.array([...])``,
products with numbers, ``inf``); ``fs`` is read when the file assigns a number to it.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable
from typing import Any

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
from allanite.terms import GaussMarkov, Term, White

NAME = "gnss-ins-sim"
TITLE = "gnss-ins-sim IMU error dict (Python)"
SUFFIXES = (".py",)
HOLDS = frozenset({"white", "markov"})
D2R = math.pi / 180.0
#: sensor -> (white key, factor to SI, drift key, factor, correlation key, offset key, factor)
KEYS = {
    "gyro": (
        "gyro_arw",
        D2R / 60.0,
        "gyro_b_stability",
        D2R / 3600.0,
        "gyro_b_corr",
        "gyro_b",
        D2R / 3600.0,
    ),
    "accel": ("accel_vrw", 1.0 / 60.0, "accel_b_stability", 1.0, "accel_b_corr", "accel_b", 1.0),
}
UNITS = {
    "gyro_b": "deg/h",
    "gyro_arw": "deg/sqrt(h)",
    "gyro_b_stability": "deg/h",
    "gyro_b_corr": "s",
    "accel_b": "m/s^2",
    "accel_vrw": "m/s/sqrt(h)",
    "accel_b_stability": "m/s^2",
    "accel_b_corr": "s",
}


def sniff(text: str) -> bool:
    """The ``gyro_arw`` key."""
    return "gyro_arw" in text or "accel_vrw" in text


def _value(node: ast.AST) -> Any:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return float(node.value)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        return -_value(node.operand)
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_value(e) for e in node.elts]
    if isinstance(node, ast.Attribute) and node.attr == "inf":
        return math.inf
    if isinstance(node, ast.Attribute) and node.attr == "pi":
        return math.pi
    if isinstance(node, ast.Name) and node.id in ("D2R", "inf", "pi"):
        return {"D2R": D2R, "inf": math.inf, "pi": math.pi}[node.id]
    if isinstance(node, ast.Call) and node.args:
        name = getattr(node.func, "attr", getattr(node.func, "id", ""))
        if name in ("array", "asarray", "float"):
            arg = node.args[0]
            if name == "float" and isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                return float(arg.value)
            return _value(arg)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
        a, b = _value(node.left), _value(node.right)
        op: Callable[[Any, Any], Any] = (
            (lambda x, y: x * y) if isinstance(node.op, ast.Mult) else (lambda x, y: x / y)
        )
        if isinstance(a, list):
            return [op(x, b) for x in a]
        if isinstance(b, list):
            return [op(a, y) for y in b]
        return op(a, b)
    line = getattr(node, "lineno", "?")
    raise ValueError(f"gnss-ins-sim file: cannot evaluate {ast.unparse(node)!r} (line {line})")


def _first(value: Any, key: str, notes: list[str]) -> float:
    if isinstance(value, list):
        if not value:
            raise ValueError(f"gnss-ins-sim: {key} is empty")
        if any(v != value[0] for v in value):
            notes.append(f"{key} differs between axes; the model is the x axis'")
        value = value[0]
    if value == math.inf:
        return math.inf
    return number(value, f"gnss-ins-sim: {key}")


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read the error dict (and ``fs`` when the file assigns it)."""
    try:
        tree = ast.parse(text)
    except SyntaxError as exc:
        raise ValueError(f"gnss-ins-sim file is not valid Python: {exc}") from None
    found: dict[str, Any] | None = None
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict) and any(
            isinstance(k, ast.Constant) and k.value in ("gyro_arw", "accel_vrw") for k in node.keys
        ):
            found = {
                k.value: _value(v)
                for k, v in zip(node.keys, node.values, strict=True)
                if isinstance(k, ast.Constant) and k.value in UNITS
            }
            break
        if (
            rate is None
            and isinstance(node, ast.Assign)
            and any(isinstance(t, ast.Name) and t.id == "fs" for t in node.targets)
        ):
            try:
                fs = _value(node.value)
                rate = float(fs[0] if isinstance(fs, list) else fs)
            except ValueError:
                pass
    if found is None:
        raise ValueError("gnss-ins-sim file: no dict with 'gyro_arw' / 'accel_vrw' keys found")
    notes: list[str] = []
    models = {}
    offsets = {}
    for sensor, (wk, wf, dk, df, ck, bk, bf) in KEYS.items():
        if wk not in found and dk not in found:
            continue
        arw = _first(found.get(wk, 0.0), wk, notes) * wf
        drift = _first(found.get(dk, 0.0), dk, notes) * df
        corr = _first(found.get(ck, math.inf), ck, notes)
        terms: list[Term] = []
        if drift > 0:
            dt = 1.0 / need_rate(rate, f"gnss-ins-sim {dk}")
            if math.isinf(corr):
                arw = math.sqrt(arw**2 + drift**2 * dt)
                notes.append(f"{ck} = inf: the simulator adds {dk} as white noise per sample")
            else:
                if not corr > dt:
                    raise ValueError(f"gnss-ins-sim: {ck} = {corr} s must exceed the period {dt} s")
                phi = 1.0 - dt / corr
                b2 = drift**2 * (-math.expm1(-2.0 * dt / corr))
                terms.append(GaussMarkov.from_ar1(phi, b2, dt))
        if arw > 0:
            terms.insert(0, White(N=arw))
        models[sensor] = sensor_model(terms, sensor)
        if bk in found:
            offsets[sensor] = _first(found[bk], bk, notes) * bf
    return ImuConfig(
        gyro=models.get("gyro"),
        accel=models.get("accel"),
        rate=rate,
        offsets=offsets,
        source_format=NAME,
        notes=tuple(notes),
    )


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
) -> Written:
    """A Python file defining ``imu_err``; the dict is rewritten whole.

    With ``template`` (an earlier gnss-ins-sim file), a sensor ``config`` has no model of
    keeps the template's values and notes, so the gyro and the accelerometer can be written
    one after the other into one file.
    """
    kept: list[str] = []
    if template is not None:
        comments = [line.strip()[1:] for line in template.splitlines() if line.strip()[:1] == "#"]
        kept = notes_of_others(comments, config.sensors)
        config = config.filled_from(read(template, rate=rate))
    rate = need_rate(rate or config.rate, "gnss-ins-sim's Gauss-Markov drift (phi = 1 - dt/T)")
    dt = 1.0 / rate
    models, dropped, projections = project_config(config, HOLDS, rate=rate, tau_range=tau_range)
    values: dict[str, float] = {}
    for sensor, (wk, wf, dk, df, ck, bk, bf) in KEYS.items():
        model = models.get(sensor)
        white = model.terms_of_type("white") if model else ()
        gm = model.terms_of_type("markov") if model else ()
        values[bk] = config.offsets.get(sensor, 0.0) / bf
        values[wk] = (white[0].values()["N"] if white else 0.0) / wf
        if gm:
            sigma, tc = gm[0].values()["sigma"], gm[0].values()["tau_c"]
            phi = math.exp(-dt / tc)
            corr = dt / (1.0 - phi)
            b = sigma * math.sqrt(1.0 - phi**2)
            values[dk] = b / math.sqrt(-math.expm1(-2.0 * dt / corr)) / df
            values[ck] = corr
        else:
            values[dk] = 0.0
            values[ck] = 100.0
    lines = ["# IMU error model for gnss-ins-sim, written by allanite", "import numpy as np", ""]
    lines += [f"# dropped: {d}" for d in dropped] + [f"# projected: {p}" for p in projections]
    lines += [f"# {note}" for note in kept]
    lines += [
        f"# {sensor}: zero noise (the source holds no {sensor} model; gnss-ins-sim needs the keys)"
        for sensor in KEYS
        if getattr(config, sensor) is None
    ]
    lines.append(f"fs = {number_text(rate)}  # Hz, the IMU rate this model was written for")
    lines.append("imu_err = {")
    for key, value in values.items():
        v = number_text(value)
        lines.append(f"    '{key}': np.array([{v}, {v}, {v}]),  # {UNITS[key]}")
    lines.append("}")
    return Written("\n".join(lines) + "\n", dropped, projections)
