"""Electrical resistance of the silver-coated thread, R(T, x).

The paper reports a ~20 % resistance change during actuation [1, Sec. II-A] but no
law. We assume a linear law (docs/decisions.md, D10), configurable:

    R = R0 (1 + beta_T (T - T0) + beta_x x / l0)

with x the contraction (m, positive when shorter) from the loaded length l0 at T0:
shorter coils bring turns closer and the silver coating cracks less, so
R falls with contraction; heating lowers the contact resistance between plies.
Defaults R0 = 25 ohm, beta_T = -1e-3 1/K, beta_x = -0.2 follow the 5-6 V, 1-1.5 W
drive of [1, Sec. V-D3] and ref. [7] of [1] (Sun & Zhao, ICRA 2018).
"""


def resistance(temp, contraction, loaded_length, electrical, ambient):
    """Return R (ohm) at temperature (degC) and contraction (m) from l0 (m)."""
    return electrical.resistance * (
        1.0 + electrical.temperature_coefficient * (temp - ambient)
        + electrical.strain_coefficient * contraction / loaded_length)


def power_from_voltage(voltage, resistance_ohm):
    """Return the Joule power V^2 / R (W) for a voltage (V) across R (ohm)."""
    return voltage * voltage / resistance_ohm
