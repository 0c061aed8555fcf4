"""Extensions of the nominal TCA model: the catalogue the diagnosis searches.

Each effect is a physical relation, neutral at its default parameter value
(``EffectParams`` in tca_params.py), so the nominal model is the extended model with
every effect switched off. The steppers call these functions, and the thermal
effects (radiation, nonlinear convection, the lags) are terms of eq. (1) in
thermal.py; the diagnosis (tca_ros.diagnosis) fits their parameters.

==================== ============================= ===================================
name                 parameter(s)                  relation
==================== ============================= ===================================
creep                creep_compliance (m/N),       Kelvin-Voigt element in series:
                     creep_time_constant (s)       dy_c/dt = (C F - y_c) / tau_c
hysteresis           hysteresis_width (K)          play operator on the actuation
                                                   temperature
radiation            emissivity (-)                eps sigma A_0 (T^4 - T_inf^4)
nonlinear_convection convection_exponent (-)       h (|T - T_inf| / dT_ref)^n
modulus_softening    extra_softening (Pa/K)        E_f falls faster with T (eq. 11)
coil_contact         coil.min_pitch_angle_deg      stroke stops at l_t sin(alpha_min)
sensor_lag           sensor_lag (s)                first-order lag of the sensor
ambient_offset       ambient_offset (K)            true T_inf = nominal + offset
power_loss           power_loss_fraction (-)       heating power (1 - eta) P
dead_time            dead_time (s)                 P_in(t) = P(t - d): the drive's delay
second_thermal_lag   second_thermal_lag (s)        tau_2 dT_f/dt = T - T_f; T_f actuates
                                                   (core vs surface, heater vs thread)
friction             friction_force F_k (N),       Coulomb friction on the free end:
                     static_friction_ratio         stick while |F - f_rod| <= F_s = r F_k,
                     r = F_s / F_k (-),            slide against F_k (Karnopp; play
                     friction_start s (-)          operator on y when massless); the
                                                   end starts at y_eq(F + s F_s)
==================== ============================= ===================================

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022 (Sec. V-D1, VI: creep, lonely
    stroke, hysteresis, coil contact left out of the model).
[2] S. Kianzad et al., "Nylon coil actuator operating temperature range and
    stiffness," Proc. SPIE 9430, 2015 (creep of nylon coils under load).
[3] J. Zhang, K. Iyer, A. Simeonov, M. C. Yip, "Modeling and inverse compensation
    of hysteresis in supercoiled polymer artificial muscles," IEEE RA-L 2(2), 2017.
[4] K. Masuya, S. Ono, K. Takagi, K. Tahara, "Modeling framework for macroscopic
    dynamics of twisted and coiled polymer actuator driven by Joule heating
    focusing on energy and convective heat transfer," Sens. Actuators A 267, 2017
    (radiation and temperature-dependent convection).
[5] F. Karami, L. Wu, Y. Tadesse, IEEE/ASME Trans. Mechatronics 26(1), 2021
    (moduli falling with temperature and load).
[6] A. Demsar, V. Bukosek, A. Kljun, "Dynamic mechanical analysis of nylon 66
    cord yarns," Fibres Text. East. Eur. 4(81), 2010 (modulus vs temperature).
[7] D. Karnopp, "Computer simulation of stick-slip friction in mechanical
    dynamic systems," J. Dyn. Syst. Meas. Control 107(1), 100-103, 1985.
[8] J. J. Moreau, "Unilateral contact and dry friction in finite freedom
    dynamics," in Nonsmooth Mechanics and Applications, CISM 302, Springer, 1988
    (the time-stepping form: the friction that holds the end over a step is
    found first, then limited to the Coulomb cone).
[9] A. Jones and J. R. Davidson, "Underwater salp-inspired soft body contraction
    with twisted coiled actuators," RoboSoft 2023 (isotonic TCA rig: a weight over
    a pulley on an encoder; its records show 1-3 mm steps and a residual offset).
"""
import math

STEFAN_BOLTZMANN = 5.670374419e-8  # W/(m^2 K^4)
KELVIN = 273.15  # K at 0 degC

#: Effect names, as used in diagnosis.json, with the parameters each one owns.
CATALOGUE = {
    'creep': ('effects.creep_compliance', 'effects.creep_time_constant'),
    'hysteresis': ('effects.hysteresis_width',),
    'radiation': ('effects.emissivity',),
    'nonlinear_convection': ('effects.convection_exponent',),
    'modulus_softening': ('effects.extra_softening',),
    'coil_contact': ('coil.min_pitch_angle_deg',),
    'sensor_lag': ('effects.sensor_lag',),
    'ambient_offset': ('effects.ambient_offset',),
    'power_loss': ('effects.power_loss_fraction',),
    'dead_time': ('effects.dead_time',),
    'second_thermal_lag': ('effects.second_thermal_lag',),
    # F_s / F_k is not searched: the stick-slip it adds makes the cost jump with it; where
    # the end starts in its band is (a muscle heated before its record starts at an edge)
    'friction': ('effects.friction_force', 'effects.friction_start'),
}


def heating_power(power, effects, delivered_ratio=1.0):
    """Return the power heating the fiber (W): (1 - eta) r P, P the logged power (W).

    eta is the 'power_loss' effect, r the calibrated ``thermal.delivered_power_ratio``.
    """
    return (1.0 - effects.power_loss_fraction) * delivered_ratio * power


def true_ambient(thermal, effects):
    """Return the true ambient temperature (degC): nominal + 'ambient_offset' (K)."""
    return thermal.ambient_temperature + effects.ambient_offset


def play_operator(temp, state, width):
    """Return the play-operator output (degC), the 'hysteresis' effect [3].

    The actuation temperature follows T only once T has moved more than width/2
    past it, so heating and cooling branches of the stroke differ by ``width`` (K).
    """
    half = 0.5 * width
    return min(max(state, temp - half), temp + half)


def creep_rate(creep_elongation, tension, effects):
    """Return dy_c/dt (m/s) of the Kelvin-Voigt creep element, 'creep' [2].

        dy_c/dt = (C F - y_c) / tau_c
    """
    return (effects.creep_compliance * tension - creep_elongation) / effects.creep_time_constant


def coulomb_friction(holding_force, at_rest, effects):
    """Return (friction (N), stuck) on the free end over one step, 'friction' [7, 8].

    ``holding_force`` (N) is the friction force that would keep the free end at
    rest over the step (along the elongation, stretching positive): in the
    massless mode f_rod(y, T) - F, in the central-difference step of eq. (18)
    also the inertia and damping of the step. Coulomb's law with stiction:

        |f_hold| <= F_s = r F_k  (at rest)  or  F_k  (sliding):  stuck, f = f_hold
        otherwise:  sliding, f = F_k sign(f_hold)  (against the motion)

    F_k is ``effects.friction_force`` (N) and r ``effects.static_friction_ratio``
    (-); ``at_rest`` (bool) is whether the end was stuck at the previous step.
    Setting the velocity to zero whenever the kinetic force can stop the end
    within the step is Karnopp's stick band [7] in the time-stepping form [8]: it
    neither chatters nor limits the explicit step. r > 1 gives stick-slip jumps
    of about (r - 1) F_k / k (k the axial stiffness, N/m; twice that with inertia).
    """
    kinetic = effects.friction_force
    limit = kinetic * effects.static_friction_ratio if at_rest else kinetic
    if abs(holding_force) <= limit:
        return holding_force, True
    return math.copysign(kinetic, holding_force), False


def friction_start_load(effects):
    """Return the friction force s F_s (N) that holds the free end where it starts, 'friction'.

    A muscle heated and cooled before its record starts with its end held at an
    edge of the static band, not at the equilibrium under its load: the end sits
    at y_eq(F + s F_s, T_0), s = ``effects.friction_start`` in [-1, 1] (-1: the
    shortened edge, where cooling left an end that friction stopped short; 1: the
    stretched edge) and F_s = r F_k the static friction (N). Every stepper starts
    the end there and reads the displacement from it (a record reads zero at its
    start; docs/decisions.md G45). Zero without friction.
    """
    return effects.friction_start * effects.friction_force * effects.static_friction_ratio


def friction_play(elongation, static_band, kinetic_band):
    """Return the elongation (m) of the massless end after its band moved, 'friction'.

    The play operator of Coulomb friction on the elongation y (m): the end stays
    at y while y_eq(F - F_s, T) <= y <= y_eq(F + F_s, T), y_eq the static
    equilibrium under the load F (N) and F_s the static friction (N); outside it
    slips to the kinetic band edge y_eq(F -+ F_k, T) on the same side. The
    bands are (lower, upper) pairs of elongations (m, floats); with
    r = 1 they are equal and this is the play (backlash) operator of [3] on y.
    """
    low_s, high_s = static_band
    low_k, high_k = kinetic_band
    if elongation > high_s:
        return high_k
    if elongation < low_s:
        return low_k
    return elongation
