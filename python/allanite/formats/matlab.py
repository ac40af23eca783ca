"""MATLAB ``gyroparams`` / ``accelparams`` for ``imuSensor`` (Sensor Fusion / Navigation Toolbox).

The discrete law
----------------
``imuSensor`` adds, per axis and per sample at ``SampleRate`` fs (dt = 1/fs), three drifts to
the ideal reading (toolbox class ``fusion.internal.IMUSensorSimulator``, R2023b and later;
"Copyright 2017-2023 The MathWorks, Inc."; the same law appears in the Simulink Coder output
of the IMU block, ``pBandwidth``/``pStdDevWhiteNoise``/``pStdDevRandWalk``):

- a bandwidth ``pBandwidth = SampleRate/2`` when ``NoiseType`` is ``"double-sided"`` (the
  default) and ``SampleRate`` when ``"single-sided"`` (``setupBandwidth``);
- white noise of per-sample std ``sqrt(pBandwidth) * NoiseDensity``
  (``setStdDevWhiteNoise``);
- a random walk whose per-sample step has std ``RandomWalk / sqrt(pBandwidth)``, starting at 0
  and added after the step (``stepRandomWalkDrift``: ``cumsum`` of the steps);
- the bias instability ``filter(Numerator, Denominator, BiasInstability * sqrt(2/(fs*Tc)) *
  randn)`` with ``Tc = 2 dt`` ("Default correlation time value to make decay factor 1/2"),
  i.e. a driving std of exactly ``BiasInstability``, filter state starting at 0. The
  coefficients are ``BiasInstabilityCoefficients``, default ``fractalcoef`` = ``fractalcoef(1,
  1)`` = Numerator 1, Denominator ``[1 -0.5]`` (Kasdin's 1/f^alpha AR filter, "equation 116",
  with one pole). ``fractalcoef(K, alpha)``: ``a_k = a_{k-1} (k - 1 - alpha/2) / k``.

So, onto Terms (``bw = pBandwidth``):

==================================  ============================================================
field                               term
==================================  ============================================================
NoiseDensity ND                     White N = ND sqrt(bw dt): ND/sqrt(2) double-sided, ND single
RandomWalk RW                       RateRandomWalk K = RW / sqrt(bw dt): sqrt(2) RW double-sided
BiasInstability BI, default coeffs  GaussMarkov AR(1) phi = 0.5 (Tc = dt/ln 2), innovation std BI:
                                    sigma = BI / sqrt(1 - 0.25); at tau >> dt it is white noise
                                    N = 2 BI sqrt(dt) -- *not* a flicker floor
BI, ``[b] / [1 -phi]``, 0<phi<1     GaussMarkov (exact), innovation std BI b
BI, ``[b] / [1 -1]``                RateRandomWalk K = BI b / sqrt(dt) (exact)
BI, ``[b] / [a0]``                  White N = BI b / a0 sqrt(dt) (exact)
BI, ``fractalcoef(K)``, K >= 2      Flicker B = BI b, approximately (said in the notes): the
                                    K-pole filter's ADEV is within 5 % of flicker from 3 to
                                    0.85 K samples, within 11 % to 6.5 K samples (+10.6 %
                                    near 2 K), 9-31 % above it at 1-2 samples, and falls as
                                    white noise beyond
ConstantBias                        constant offset
==================================  ============================================================

Consequence (the "sqrt(2) gotcha"; MATLAB Answers 2006792, "Why doesn't the noise density of
the Allan deviation plot match the noise density of imuSensor?", Aug 2023: ``NoiseDensity`` 0.1
at 100 Hz "indicates a noise density of 0.07"): with the default double-sided NoiseType the
Allan deviation at tau = 1 s is NoiseDensity/sqrt(2), and ``RandomWalk`` reads sqrt(2) times
larger. The code of MathWorks' example "Inertial Sensor Noise Analysis Using Allan Variance"
sets ``'NoiseType', 'single-sided'`` "to match the parameter scaling" and
``fractalcoef(500)`` for the bias instability. With the default filter ``BiasInstability`` is
a 1.44-sample Gauss-Markov process, i.e. extra white noise, not a bias-instability floor; only
``fractalcoef(K)`` with many poles makes it flicker (B = BiasInstability in the IEEE
convention, ADEV floor 0.664 B, as the fractalcoef filter's 1/f PSD gives).

Sources: the toolbox class text quoted above (``setupBandwidth``, ``setupBiasInstabilityDrift``,
``setStdDev*``, ``step*Drift``; ``fractalcoef.m``: "poles are from equation 116" of N. J.
Kasdin, Proc. IEEE 83(5), 1995), found in public copies of the toolbox files and in Simulink
Coder output of the IMU block; the gyroparams reference page ("See the Algorithms section of
imuSensor"), the fractalcoef reference page ("Filter coefficients for fractal noise generation
... power spectral density of 1/f", since R2023b) and the example "Introduction to Simulating
IMU Measurements" (``NoiseType: "double-sided"`` in the default display). Not run against
MATLAB itself (none here); the 0.0707 of the Answers thread is reproduced by the law.
Releases before R2023b have no NoiseType/BiasInstabilityCoefficients; whether their fixed
filter and bandwidth were the same defaults is not established here.

Reading
-------
``name = gyroparams('Field', value, ...)`` (``...`` continuations; ``IMU.Gyroscope = ...``
too) and ``name.Field = value;`` assignments; values may be numbers, vectors (the first axis
is taken, noted), strings, ``fractalcoef(K, alpha)``, ``struct('Numerator', .,
'Denominator', .)`` or a variable holding one of these. ``SampleRate`` comes from ``rate=``,
else from ``imuSensor(..., 'SampleRate', fs)`` / ``x.SampleRate = fs``, else imuSensor's
default 100 Hz (noted); it only matters for the bias-instability filter.

Writing
-------
``NoiseType`` ``'single-sided'`` (so NoiseDensity = N and RandomWalk = K exactly), a
Gauss-Markov bias as ``BiasInstability`` with its exact first-order ``struct`` coefficients
at the rate, and ``ConstantBias``. Flicker and other slow terms are projected onto that
Gauss-Markov bias over the stated tau range (:mod:`allanite.formats.projection`), never
silently. For MATLAB's own 1/f filter set ``'BiasInstabilityCoefficients', fractalcoef(K)``
with ``K`` >= tau_max * fs / 6.5 by hand: it is read back as flicker.
"""

from __future__ import annotations

import math
import re

import numpy as np

from allanite.formats._text import number_text
from allanite.formats.base import (
    ImuConfig,
    Written,
    merge_same,
    need_rate,
    number,
    sensor_model,
    shown,
)
from allanite.formats.projection import project_config
from allanite.terms import Flicker, GaussMarkov, RateRandomWalk, Term, White

NAME = "matlab"
TITLE = "MATLAB gyroparams/accelparams script"
SUFFIXES = (".m",)
HOLDS = frozenset({"white", "markov", "rrw"})
#: noise fields and the term each maps onto (the bias instability one with its coefficients)
FIELDS = {"NoiseDensity": "white", "BiasInstability": "markov", "RandomWalk": "rrw"}
NOISE_TYPES = ("double-sided", "single-sided")
#: imuSensor's SampleRate when the script does not set one
DEFAULT_RATE = 100.0
#: Kasdin's K-pole filter follows flicker (ADEV) within 5 % from 3 to 0.85 K samples and within
#: 11 % to 6.5 K samples (computed exactly, checked in tests/test_formats.py)
FRACTAL_WITHIN_5 = 0.85
FRACTAL_WITHIN_11 = 6.5
UNITS = {
    "gyro": {
        "NoiseDensity": "(rad/s)/sqrt(Hz)",
        "BiasInstability": "rad/s",
        "RandomWalk": "(rad/s)*sqrt(Hz)",
        "ConstantBias": "rad/s",
    },
    "accel": {
        "NoiseDensity": "(m/s^2)/sqrt(Hz)",
        "BiasInstability": "m/s^2",
        "RandomWalk": "(m/s^2)*sqrt(Hz)",
        "ConstantBias": "m/s^2",
    },
}
FUNCTION = {"gyro": "gyroparams", "accel": "accelparams"}
#: the imuSensor property that takes each sensor's parameter object
ROLE = {"gyro": "Gyroscope", "accel": "Accelerometer"}
_NUMBER = r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?"
COEFFICIENTS = "BiasInstabilityCoefficients"
#: deepest bracket nesting read (a parameter script nests a few levels)
MAX_DEPTH = 50


def sniff(text: str) -> bool:
    """A ``gyroparams``/``accelparams`` call."""
    return "gyroparams" in text or "accelparams" in text


def fractal_coefficients(poles: int, alpha: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """MATLAB ``fractalcoef(poles, alpha)``: Numerator ``[1]`` and Kasdin's AR denominator."""
    if poles < 1 or int(poles) != poles:
        raise ValueError(
            f"fractalcoef: the number of poles must be a positive integer, got {poles}"
        )
    if not 0.0 < alpha < 2.0:
        raise ValueError(f"fractalcoef: alpha must lie in (0, 2), got {alpha}")
    k = np.arange(1, int(poles) + 1, dtype=np.float64)
    return np.ones(1), np.concatenate([[1.0], np.cumprod((k - 1.0 - alpha / 2.0) / k)])


# --- a small MATLAB expression reader -----------------------------------------------------
def _split_top(text: str) -> list[str]:
    """Split at top-level commas (outside brackets and quotes)."""
    parts, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i].strip())
            start = i + 1
    parts.append(text[start:].strip())
    return [p for p in parts if p]


def _calls(code: str, func: str) -> list[tuple[str | None, str]]:
    """``(assigned name or None, argument text)`` of every ``func(...)`` call in ``code``.

    Bounded time: the closing bracket of every ``(`` is found in one pass; brackets nested
    deeper than :data:`MAX_DEPTH` are refused (each level is read again by its caller) and an
    unclosed call runs to the end of the text.
    """
    closing: dict[int, int] = {}
    stack: list[int] = []
    for i, ch in enumerate(code):
        if ch == "(":
            stack.append(i)
            if len(stack) > MAX_DEPTH:
                raise ValueError(
                    f"MATLAB script: brackets nested deeper than {MAX_DEPTH} (at character "
                    f"{i}); this is not an IMU parameter script"
                )
        elif ch == ")" and stack:
            closing[stack.pop()] = i
    out = []
    for match in re.finditer(rf"(?:(?<![\w.])([\w.]+)\s*=\s*)?\b{func}\s*\(", code):
        end = closing.get(match.end() - 1, len(code))
        out.append((match.group(1), code[match.end() : end]))
    return out


def _string(text: str) -> str | None:
    text = text.strip()
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"":
        return text[1:-1]
    return None


def _pairs(args: str) -> dict[str, str]:
    """Name-value pairs of a call (leading positional arguments such as 'accel-gyro' skipped)."""
    items = _split_top(args)
    out = {}
    i = 0
    while i < len(items):
        name = _string(items[i])
        if name is not None and i + 1 < len(items) and re.fullmatch(r"[A-Za-z]\w*", name):
            out[name] = items[i + 1]
            i += 2
        else:
            i += 1
    return out


class _Script:
    """Field values of the gyroparams/accelparams objects of a MATLAB script, as text."""

    def __init__(self, text: str) -> None:
        code = re.sub(r"%[^\n]*", "", text)
        code = re.sub(r"\.\.\.[^\n]*\n", " ", code)
        self.code = code
        self.variables = {
            m.group(1): m.group(2).strip()
            for m in re.finditer(r"(?m)^[ \t]*(\w+)[ \t]*=[ \t]*([^;\n]+)", code)
        }
        self.fields: dict[str, dict[str, str]] = {}
        owners: dict[str, str] = {}
        for sensor, func in FUNCTION.items():
            for name, args in _calls(code, func):
                if name:
                    owners[name] = sensor
                self.fields.setdefault(sensor, {}).update(_pairs(args))
        for match in re.finditer(r"(?<![\w.])([\w.]+)\s*=(?!=)\s*([^;\n]+)", code):
            path, value = match.group(1), match.group(2).strip()
            for owner, sensor in owners.items():
                if not path.startswith(owner + "."):
                    continue
                field = path[len(owner) + 1 :]
                sub = (f"{COEFFICIENTS}.Numerator", f"{COEFFICIENTS}.Denominator")
                if re.fullmatch(r"\w+", field) or field in sub:
                    self.fields[sensor][field] = value

    def resolve(self, value: str) -> str:
        seen = 0
        while re.fullmatch(r"[A-Za-z]\w*", value) and value in self.variables and seen < 10:
            value, seen = self.variables[value], seen + 1
        return value

    def sample_rate(self) -> float | None:
        """``SampleRate`` given to ``imuSensor`` (argument or property), or None."""
        calls = _calls(self.code, "imuSensor")
        found = [_pairs(args).get("SampleRate") for _, args in calls]
        for name in {name for name, _ in calls if name}:
            pattern = rf"(?<![\w.]){re.escape(name)}\.SampleRate\s*=\s*([^;\n]+)"
            found += [m.group(1) for m in re.finditer(pattern, self.code)]
        values = [v for v in found if v is not None]
        if not values:
            return DEFAULT_RATE if found else None
        return number(self.resolve(values[0]), "imuSensor SampleRate")


def _vector(text: str, where: str) -> list[float]:
    text = text.strip()
    body = text[1:-1] if text.startswith("[") and text.endswith("]") else text
    parts = [p for p in re.split(r"[\s,;]+", body.strip()) if p]
    if not parts or not all(re.fullmatch(_NUMBER, p) for p in parts):
        raise ValueError(f"{where}: expected numbers, got {shown(text)}")
    return [float(p) for p in parts]


def _scalar(text: str, where: str, notes: list[str], *, signed: bool = False) -> float:
    values = _vector(text, where)
    if any(v != values[0] for v in values):
        notes.append(f"{where} differs between axes; the model is the first axis'")
    return values[0] if signed else number(values[0], where)


def _noise_type(text: str, where: str) -> str:
    value = _string(text)
    # MATLAB's validatestring: a case-insensitive unique prefix
    found = [t for t in NOISE_TYPES if value and t.startswith(value.lower())]
    if len(found) != 1:
        raise ValueError(f"{where}: expected 'double-sided' or 'single-sided', got {text}")
    return found[0]


def _coefficients(
    script: _Script, values: dict[str, str], where: str
) -> tuple[list[float], list[float], str]:
    """Numerator, denominator and a description of ``BiasInstabilityCoefficients``."""
    num, den, how = [1.0], [1.0, -0.5], "the default fractalcoef (Denominator [1 -0.5])"
    text = script.resolve(values.get(COEFFICIENTS, "")).strip()
    call = re.fullmatch(r"fractalcoef\s*(?:\((.*)\))?", text, flags=re.S)
    if call:
        args = [script.resolve(a) for a in _split_top(call.group(1) or "")]
        poles = _vector(args[0], f"{where} fractalcoef")[0] if args else 1.0
        alpha = _vector(args[1], f"{where} fractalcoef")[0] if len(args) > 1 else 1.0
        n, d = fractal_coefficients(int(poles) if poles == int(poles) else -1, alpha)
        num, den, how = list(n), list(d), f"fractalcoef({int(poles)}, {alpha:g})"
    elif text.startswith("struct"):
        pairs = _pairs(text[text.index("(") + 1 : text.rindex(")")])
        if "Numerator" not in pairs or "Denominator" not in pairs:
            raise ValueError(f"{where}: struct needs 'Numerator' and 'Denominator' fields")
        num = _vector(script.resolve(pairs["Numerator"]), f"{where}.Numerator")
        den = _vector(script.resolve(pairs["Denominator"]), f"{where}.Denominator")
        how = "struct coefficients"
    elif text:
        raise ValueError(
            f"{where}: cannot read {text!r}; give fractalcoef(K, alpha) or "
            "struct('Numerator', b, 'Denominator', [1 -phi])"
        )
    if f"{COEFFICIENTS}.Numerator" in values:
        num = _vector(script.resolve(values[f"{COEFFICIENTS}.Numerator"]), f"{where}.Numerator")
        how = "coefficients set by field"
    if f"{COEFFICIENTS}.Denominator" in values:
        key = f"{COEFFICIENTS}.Denominator"
        den = _vector(script.resolve(values[key]), f"{where}.Denominator")
        how = "coefficients set by field"
    return num, den, how


def _bias_term(
    bi: float,
    num: list[float],
    den: list[float],
    how: str,
    rate: float,
    where: str,
    notes: list[str],
) -> Term:
    """The term of ``filter(num, den, bi * randn)`` sampled at ``rate``."""
    dt = 1.0 / rate
    if len(num) != 1 or not den or den[0] == 0:
        raise ValueError(
            f"{where}: only a scalar Numerator and a Denominator starting with a nonzero value "
            f"have an allanite term, got Numerator {num}, Denominator {den}"
        )
    drive = bi * abs(num[0] / den[0])
    a = [d / den[0] for d in den]
    if len(a) == 1:
        return White(N=drive * math.sqrt(dt))
    if len(a) == 2 and a[1] == -1.0:
        return RateRandomWalk(K=drive / math.sqrt(dt))
    if len(a) == 2 and 0.0 < -a[1] < 1.0:
        return GaussMarkov.from_ar1(-a[1], drive**2, dt)
    _, kasdin = fractal_coefficients(len(a) - 1, 1.0)
    if np.allclose(a, kasdin, rtol=1e-9, atol=1e-12):
        poles = len(a) - 1
        notes.append(
            f"{where} {how} is read as flicker B = BiasInstability: MATLAB's {poles}-pole "
            f"filter follows flicker within 5 % of the ADEV from {3 * dt:.3g} to "
            f"{FRACTAL_WITHIN_5 * poles * dt:.3g} s and within 11 % to "
            f"{FRACTAL_WITHIN_11 * poles * dt:.3g} s at {rate:g} Hz (9-31 % higher at 1-2 "
            "samples); beyond, its ADEV falls as white noise"
        )
        return Flicker(B=float(drive))
    raise ValueError(
        f"{where}: BiasInstabilityCoefficients Denominator {den} has no allanite term; use "
        "a first-order filter (Denominator [1 -phi], 0 < phi <= 1) or fractalcoef(K) (alpha 1)"
    )


def read(text: str, *, rate: float | None = None) -> ImuConfig:
    """Read every ``gyroparams``/``accelparams`` object of the script (law: module docstring)."""
    script = _Script(text)
    if not script.fields:
        raise ValueError("MATLAB script: no gyroparams(...) or accelparams(...) object found")
    notes: list[str] = []
    found_rate = script.sample_rate()
    if rate is not None and found_rate is not None and abs(found_rate - rate) > 1e-9 * rate:
        notes.append(f"imuSensor SampleRate {found_rate:g} Hz overridden by the given {rate:g} Hz")
    rate = rate if rate is not None else found_rate
    models = {}
    offsets = {}
    for sensor, values in script.fields.items():
        func = FUNCTION[sensor]
        noise_type = "double-sided"
        if "NoiseType" in values:
            noise_type = _noise_type(script.resolve(values["NoiseType"]), f"{func} NoiseType")
        # bandwidth times dt: 1/2 double-sided, 1 single-sided (independent of the rate)
        bw_dt = 0.5 if noise_type == "double-sided" else 1.0
        get = {
            name: _scalar(script.resolve(values[name]), f"{func} {name}", notes)
            for name in FIELDS
            if name in values
        }
        terms: list[Term] = []
        if get.get("NoiseDensity", 0.0) > 0:
            terms.append(White(N=get["NoiseDensity"] * math.sqrt(bw_dt)))
        if get.get("BiasInstability", 0.0) > 0:
            num, den, how = _coefficients(script, values, f"{func} {COEFFICIENTS}")
            if rate is None:
                notes.append(
                    f"{func} BiasInstability: no SampleRate in the script, imuSensor's default "
                    f"{DEFAULT_RATE:g} Hz assumed (give the rate to change it)"
                )
            used = need_rate(rate if rate is not None else DEFAULT_RATE, f"{func} filter")
            terms.append(_bias_term(get["BiasInstability"], num, den, how, used, func, notes))
        if get.get("RandomWalk", 0.0) > 0:
            terms.append(RateRandomWalk(K=get["RandomWalk"] / math.sqrt(bw_dt)))
        if "ConstantBias" in values:
            where = f"{func} ConstantBias"
            offsets[sensor] = _scalar(
                script.resolve(values["ConstantBias"]), where, notes, signed=True
            )
        known = {*FIELDS, "ConstantBias", "NoiseType", COEFFICIENTS}
        ignored = sorted(v for v in values if v not in known and not v.startswith(COEFFICIENTS))
        if ignored:
            notes.append(f"{func}: {', '.join(ignored)} not part of the noise model")
        models[sensor] = merge_same(sensor_model(terms, sensor))
    return ImuConfig(
        gyro=models.get("gyro"),
        accel=models.get("accel"),
        rate=rate,
        offsets=offsets,
        source_format=NAME,
        notes=tuple(notes),
    )


def _exact(value: float) -> str:
    """A float as MATLAB text that parses back to the same double."""
    return repr(float(value))


def fields(
    config: ImuConfig,
    *,
    rate: float | None = None,
    tau_range: tuple[float, float] | None = None,
) -> tuple[dict[str, dict[str, str]], list[str], list[str]]:
    """The ``gyroparams``/``accelparams`` field values (MATLAB text) that reproduce ``config``.

    Returns ``(fields per sensor, dropped, projections)``; the values assume imuSensor's
    ``SampleRate`` = ``rate`` (else the config's, else 100 Hz, the imuSensor default).
    """
    rate = rate or config.rate or DEFAULT_RATE
    dt = 1.0 / need_rate(rate, "the MATLAB bias-instability filter")
    models, dropped, projections = project_config(config, HOLDS, rate=rate, tau_range=tau_range)
    out: dict[str, dict[str, str]] = {}
    for sensor, model in models.items():
        values = {"NoiseType": "'single-sided'"}
        white = model.terms_of_type("white")
        values["NoiseDensity"] = number_text(white[0].values()["N"] if white else 0.0)
        markov = model.terms_of_type("markov")
        if markov:
            gm = markov[0]
            phi = float(_exact(math.exp(-dt / gm.values()["tau_c"])))
            drive = gm.values()["sigma"] * math.sqrt(1.0 - phi**2)
            values["BiasInstability"] = number_text(drive)
            values[COEFFICIENTS] = f"struct('Numerator', 1, 'Denominator', [1 {_exact(-phi)}])"
        else:
            values["BiasInstability"] = "0"
        rrw = model.terms_of_type("rrw")
        values["RandomWalk"] = number_text(rrw[0].values()["K"] if rrw else 0.0)
        if sensor in config.offsets:
            values["ConstantBias"] = number_text(config.offsets[sensor])
        out[sensor] = values
    return out, dropped, projections


def write(
    config: ImuConfig,
    *,
    rate: float | None = None,
    template: str | None = None,
    tau_range: tuple[float, float] | None = None,
    names: dict[str, str] | None = None,
) -> Written:
    """MATLAB code building the ``gyroparams``/``accelparams`` objects and the ``imuSensor``.

    The script ends with ``imu = imuSensor('accel-gyro', 'SampleRate', fs, ...)``, so the
    rate the parameters were written for is read back with them. With ``template`` (an
    earlier script), a sensor ``config`` has no model of keeps the template's parameters and
    notes: the gyro and the accelerometer can be written one after the other into one script.
    """
    names = {"gyro": "gyro", "accel": "accel", **(names or {})}
    for name in names.values():
        if not name.isidentifier():
            raise ValueError(f"name must be a MATLAB identifier, got {name!r}")
    kept: list[str] = []
    if template is not None:
        prefix = "% not representable in gyroparams/accelparams: "
        earlier = [
            part
            for line in template.splitlines()
            if line.startswith(prefix)
            for part in line[len(prefix) :].split("; ")
        ]
        others = [s for s in FUNCTION if s not in config.sensors]
        kept = [n for n in earlier if re.match(rf"({'|'.join(others) or '$^'})\b", n)]
        config = config.filled_from(read(template, rate=rate))
    used = rate or config.rate or DEFAULT_RATE
    table, dropped, projections = fields(config, rate=used, tau_range=tau_range)
    lines: list[str] = []
    for sensor, values in table.items():
        kind_text = "gyro" if sensor == "gyro" else "accelerometer"
        lines.append(f"% {kind_text} noise parameters exported by allanite (SI units) for")
        lines.append(
            f"% imuSensor('SampleRate', {number_text(used)}): single-sided, so NoiseDensity = N "
            "and RandomWalk = K"
        )
        lines.append(f"{names[sensor]} = {FUNCTION[sensor]}( ...")
        keys = list(values)
        for i, key in enumerate(keys):
            end = ");" if i == len(keys) - 1 else ", ..."
            unit = UNITS[sensor].get(key, "")
            lines.append(f"    '{key}', {values[key]}{end}" + (f"  % {unit}" if unit else ""))
    args = [f"'SampleRate', {number_text(used)}"]
    args += [f"'{ROLE[s]}', {names[s]}" for s in table]
    lines.append(
        "% the IMU these parameters were written for (its SampleRate is part of the model)"
    )
    lines.append(f"imu = imuSensor('accel-gyro', {', '.join(args)});")
    skipped = dropped + projections + kept
    if skipped:
        lines.append(f"% not representable in gyroparams/accelparams: {'; '.join(skipped)}")
    return Written("\n".join(lines) + "\n", dropped, projections)
