"""Read a :class:`allanite.model.NoiseModel` as the error laws' plain coefficients.

Mapping (second-order statistics are all the error variances depend on, so the mapped terms
give exact error variances):

=================  ==========================================================================
term               error-law input
=================  ==========================================================================
``white`` N        white noise N (several add as N^2)
``rrw`` K          Wiener process, intensity ``Q = K^2`` (several add as K^2)
``turn_on_bias``   random constant (several add in quadrature)
``markov``         Gauss-Markov (sigma, tau_c)
``telegraph``      Gauss-Markov (amplitude, tau_c): the same autocovariance ``a^2 e^{-|t|/Tc}``
``lowpass_white``  Gauss-Markov with ``tau_c = 1/(2 pi bandwidth)``, ``sigma = N/sqrt(2 tau_c)``
``flicker`` B      the simulation's bank of Gauss-Markov processes plus white noise
                   (:func:`allanite.simulation.flicker.flicker_bank`), one budget row
=================  ==========================================================================

Quantization, rate ramp, sines, drifting lines, resonances, warm-up, bias steps and spikes have no
error law here; they are listed in :attr:`SensorNoise.ignored`.
"""

from __future__ import annotations

import math
from typing import Any

from allanite.impact.sensor import MarkovNoise, SensorNoise

__all__ = ["FLICKER_DT", "FLICKER_HORIZON", "as_sensor_noise", "sensor_noise_from_model"]

#: sample period (s) that sets the high cutoff of the flicker bank (5 Hz: far above the
#: frequencies that drive navigation errors)
FLICKER_DT = 0.1
#: longest time (s) the flicker bank's correlation times must cover (10 days)
FLICKER_HORIZON = 10 * 86400.0


def sensor_noise_from_model(model: Any, *, sensor: str, accel_scale: float = 1.0) -> SensorNoise:
    """Convert a NoiseModel to :class:`SensorNoise` in SI units.

    Parameters
    ----------
    model : allanite.model.NoiseModel
        The sensor's noise model.
    sensor : {"gyro", "accel"}
        A gyro model is converted from its rate unit to rad/s. An accelerometer model in an
        acceleration unit (``m/s^2``, ``mg``, ``ug``, ...) is converted to m/s^2; one whose
        units do not name an acceleration has its coefficients multiplied by ``accel_scale``.
    accel_scale : float
        SI value (m/s^2) of one unit of an accelerometer model's "rate", for models whose
        units are not an acceleration (must stay 1 for a model in m/s^2, g, mg, ...).

    Returns
    -------
    SensorNoise
    """
    from allanite.model import NoiseModel

    if not isinstance(model, NoiseModel):
        raise TypeError(f"expected an allanite NoiseModel, got {type(model).__name__}")
    if sensor == "gyro":
        terms = model.in_units("rad/s").terms
        scale = 1.0
    elif sensor == "accel":
        if not (isinstance(accel_scale, (int, float)) and math.isfinite(accel_scale)):
            raise TypeError(f"accel_scale must be a finite number, got {accel_scale!r}")
        if accel_scale <= 0:
            raise ValueError(f"accel_scale must be > 0 (m/s^2 per model unit), got {accel_scale}")
        terms = model.terms
        scale = float(accel_scale)
        if model.sensor == "accelerometer":  # the model's unit says what its rate is
            if scale != 1.0:
                raise ValueError(
                    f"the model is already in {model.units['rate']!r}, an acceleration; leave "
                    "accel_scale at 1 (it is for models whose units are not an acceleration)"
                )
            terms = model.in_units("m/s^2").terms
    else:
        raise ValueError(f"sensor must be 'gyro' or 'accel', got {sensor!r}")

    white2 = rrw2 = const2 = 0.0
    markov: list[MarkovNoise] = []
    ignored: list[str] = []
    term: Any
    for term in terms:
        kind = term.type
        if kind == "white":
            white2 += (term.N * scale) ** 2
        elif kind == "rrw":
            rrw2 += (term.K * scale) ** 2
        elif kind == "turn_on_bias":
            const2 += (term.sigma * scale) ** 2
        elif kind == "markov":
            markov.append(MarkovNoise(term.sigma * scale, term.tau_c))
        elif kind == "telegraph":
            markov.append(MarkovNoise(term.amplitude * scale, term.tau_c, source="telegraph"))
        elif kind == "lowpass_white":
            tau_f = 1.0 / (2.0 * math.pi * term.bandwidth)
            markov.append(
                MarkovNoise(term.N * scale / math.sqrt(2.0 * tau_f), tau_f, source="lowpass_white")
            )
        elif kind == "flicker":
            from allanite.simulation.flicker import flicker_bank

            tcs, sigmas, white_n = flicker_bank(
                term.B * scale,
                FLICKER_DT,
                cutoff_hz=term.f0,
                n_samples=int(FLICKER_HORIZON / FLICKER_DT),
            )
            label = f"flicker(B={term.B * scale:.3g})"
            markov.extend(
                MarkovNoise(float(s), float(tc), source=label)
                for tc, s in zip(tcs, sigmas, strict=True)
            )
            if white_n > 0:
                # the bank's white part as a Gauss-Markov of the same low-frequency PSD N^2
                tau_w = FLICKER_DT / 4.0
                markov.append(MarkovNoise(white_n / math.sqrt(2.0 * tau_w), tau_w, source=label))
        else:
            ignored.append(kind)
    return SensorNoise(
        constant=math.sqrt(const2),
        white=math.sqrt(white2),
        random_walk=math.sqrt(rrw2),
        markov=tuple(markov),
        ignored=tuple(ignored),
    )


def as_sensor_noise(obj: Any, *, name: str, accel_scale: float = 1.0) -> SensorNoise:
    """Accept a :class:`SensorNoise` or a NoiseModel (converted to SI); anything else is an error.

    Parameters
    ----------
    obj : SensorNoise or allanite.model.NoiseModel
        The sensor's noise.
    name : {"gyro", "accel"}
        Which sensor (selects the conversion; also used in error messages).
    accel_scale : float
        m/s^2 per unit of an accelerometer NoiseModel's coefficients.
    """
    if isinstance(obj, SensorNoise):
        return obj
    if hasattr(obj, "terms"):
        return sensor_noise_from_model(obj, sensor=name, accel_scale=accel_scale)
    raise TypeError(
        f"{name} must be an allanite.impact.SensorNoise or an allanite NoiseModel, got "
        f"{type(obj).__name__}"
    )
