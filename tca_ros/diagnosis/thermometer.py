"""The thermometer as a witness of the effects that act through the temperature.

Radiation, nonlinear convection, an ambient offset, a power loss and a dead time
of the drive change the stroke only through the thread's temperature (eq. 1;
model/effects.py): they are terms of the heat balance. With a thermometer the
record shows that temperature. A fit of such an effect that predicts the stroke
better while it predicts the measured temperature worse than the model it
replaces has changed the stroke by some other way than its own: the thermometer
refutes it as the cause, however well it predicts the stroke (decisions G86;
seed 9653, a gain that fades over the record, outside the catalogue, was
explained by a nonlinear convection that raised the held-out temperature error
from 2.4 to 3.1 K).

"Worse" is the search's 1 % rule turned round (G46): the held-out RMS of the
temperature less each record's drift, above the replaced model's by more than
THERMOMETER_SLACK. The deviance of that channel alone cannot say it: the worse
temperature of such a fit is a slow level, which the noise model's AR whitening
takes for noise (9653: -2.6 against a penalty of 4.3).
"""
from tca_ros.diagnosis.verdict import pooled_heldout_rmse
from tca_ros.model.effects import CATALOGUE

#: the catalogue effects that act on the stroke only through the temperature (eq. 1)
THROUGH_TEMPERATURE = ('radiation', 'nonlinear_convection', 'ambient_offset', 'power_loss',
                       'dead_time')
CHANNEL = 'temperature'
#: a fit of such an effect may predict the measured temperature this much worse (-)
THERMOMETER_SLACK = 0.05


def thermometer_refutes(names, values, problems, base_sims, sims, candidates):
    """Return [(dotted name, value, what)] of ``names``' values the thermometer refutes.

    ``names``: the effects of a fit (all of them through the temperature, else none
    is refuted: another effect of the fit may move the temperature for its own
    reason); ``values``: its dotted values; ``problems``, ``base_sims`` and
    ``sims``: the records' FitProblems and the record-rate simulations of the
    model replaced and of the fit. Empty without a thermometer, and for a fit
    whose value the thermometer measures directly and supports (an ambient
    offset within the band of the room read at rest, ``Candidate.measured`` of
    ``candidates``): that reading is the evidence on it, the held-out part's
    temperature carries the rest of the model's errors too.
    """
    if CHANNEL not in problems[0].channels or not names \
            or not all(n in THROUGH_TEMPERATURE for n in names):
        return []
    if any(p in values and low <= values[p] <= high for c in candidates if c.name in names
           for p, (low, high, _) in c.measured.items()):
        return []
    before, after = (pooled_heldout_rmse(problems, s, [CHANNEL], detrend=True)[CHANNEL]
                     for s in (base_sims, sims))
    if not after > (1.0 + THERMOMETER_SLACK) * before:
        return []
    what = (f'the thermometer: its held-out temperature, drift removed, predicted '
            f'{100.0 * (after / before - 1.0):.0f} % worse than without it '
            f'({after:.3g} K against {before:.3g} K)')
    return [(p, values[p], what) for name in names for p in CATALOGUE[name] if p in values]
