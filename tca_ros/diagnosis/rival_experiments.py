"""The measurement that would separate rival effects the records explain alike (issue 25).

When the joint stage (joint.py) finds another catalogue effect explaining the records
about as well as the one it names, the report says they are rivals and which
experiment would tell them apart. Each rival's joint calibration (the nominal
parameters and its effect's, on the same records) is a muscle that fits the records;
the calibration's experiment engine (calibration/experiments.py) simulates every
candidate experiment with both and keeps the one whose predictions differ most
against its sensor's noise. Measured with the catalogue's model (effects.py): a sensor
lag delays the displacement reading and a second thermal lag the actuating
temperature, neither the measured temperature, so a temperature channel cannot tell
them apart; a load step can (the coil's elastic response is immediate behind a
thermal lag, delayed by a sensor lag).
"""
from tca_ros.calibration.experiments import separating_experiment


def rival_experiment(named, rival):
    """Return the Experiment separating two JointFits, or None (no calibration to simulate).

    ``named`` and ``rival`` are joint.JointFit, each with its joint Calibration (the
    values the records fit with that effect); the experiments are built on the
    named fit's records and noise (m of displacement, K of a thermocouple).
    """
    if named.calibration is None or rival.calibration is None:
        return None
    cal = named.calibration
    values = [named.calibration.report.values, rival.calibration.report.values]
    return separating_experiment(cal, values, (named.name, rival.name), 'effects')


def rival_experiment_notes(named, rivals):
    """Return the report's notes: per rival, the experiment that separates it from ``named``.

    Each note names both effects, the experiment and how far apart the two
    jointly calibrated muscles are there and on the records (RMS, against the
    sensor noise; 'separates' at experiments.SEPARATES noise units).
    """
    notes = []
    for rival in rivals:
        e = rival_experiment(named, rival)
        if e is None:
            continue
        told = ('separates them' if e.separates else
                'is the best tried and would not separate them either')
        notes.append(f'{named.name} and {rival.name} are rivals: calibrated jointly each fits '
                     f'these records (the two differ by {e.on_records:.3g} m RMS on them); '
                     f'{e.experiment} {told}: simulated with each, they differ by '
                     f'{e.difference:.3g} {e.unit} RMS there (noise {e.noise:.3g} {e.unit})')
    return notes
