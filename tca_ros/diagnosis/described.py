"""What the description says about an effect that is a described value moved.

Some catalogue effects are a value the description states, under another name
(calibration/candidates.py, twin_shift): a power loss is a lower delivered power,
an ambient offset the room moved, radiation and nonlinear convection a heat loss
other than the stated one. How far a fit moves that value, in the description's
prior spreads, is evidence about the effect: within SHIFT_Z the description
admits it (:func:`admitted_effects`: nothing to name), and beyond, the move costs
what the prior says it costs when rival explanations are weighed
(:func:`description_cost`; docs/diagnosis_method.md, "Joint calibration").
"""
from tca_ros.calibration.candidates import twin_shift
from tca_ros.calibration.physical_priors import SHIFT_Z


def admitted_effects(names, params, described, spreads, thermometer=True):
    """Return the effects of ``names`` whose size in ``params`` the description admits.

    Those that are a nominal value under another name (candidates.ABSORBED: a
    power loss is a lower delivered power; candidates.STATED_OFFSETS: an ambient
    offset is the room's temperature moved) and move it no more than SHIFT_Z prior
    spreads from the description ``described`` (candidates.twin_shift): a joint
    fit that needs no more says the muscle is as described, not that it has the
    effect (a 2.9 % loss where the delivered power is stated to 4.6 %: decisions G64;
    an offset of -1.4 K where the room is stated to 1 K: G66; a radiation whose
    linearised loss keeps the heat loss within its stated spread, candidates.LOSS_TWINS:
    G67). ``thermometer``: the
    records have a temperature channel (else an offset is also T_z moved).
    """
    shifts = {n: twin_shift(n, params, described, spreads, thermometer) for n in names}
    return tuple(n for n, z in shifts.items() if z is not None and z <= SHIFT_Z)


def description_cost(names, params, described, spreads, thermometer=True):
    """Return sum z^2 (-) over ``names`` of how far each moves its described twin.

    z is candidates.twin_shift in prior spreads (0 for an effect without a twin
    or a twin without a stated spread); arguments as :func:`admitted_effects`.
    Under the description's Gaussian prior, -2 ln of the prior density of that
    move relative to no move is z^2: on the scale of the penalised held-out gain
    D - k ln n (twice a log-likelihood ratio), so the two add when rival fits are
    weighed (joint.JointFit.weighed, decisions G84).
    """
    shifts = (twin_shift(n, params, described, spreads, thermometer) for n in names)
    return sum(z * z for z in shifts if z is not None)
