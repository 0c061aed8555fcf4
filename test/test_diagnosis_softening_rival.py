"""Rivals left open: a softening beside a gain kept down on one load (G88), weighed (G89)."""
from types import SimpleNamespace

import numpy as np

from tca_ros.calibration.candidates import Candidate
from tca_ros.diagnosis import family_rivals as rivals_module
from tca_ros.diagnosis.family_rivals import family_rivals
from tca_ros.diagnosis.joint import JointFit
from tca_ros.diagnosis.rivals import rival_note, undecided_rivals

SOFTENING = 'modulus_softening'
CANDIDATES = [Candidate(name, (SimpleNamespace(name=dotted),), ((1.0,),)) for name, dotted in
              (('creep', 'effects.creep_compliance'), (SOFTENING, 'effects.extra_softening'),
               ('sensor_lag', 'effects.sensor_lag'))]


def _calibration(gain_z):
    """A Calibration whose actuation gain moved ``gain_z`` prior spreads."""
    return SimpleNamespace(plausibility=lambda: [SimpleNamespace(name='actuation_gain', z=gain_z)])


def _fit(name, criterion, gain_z):
    return JointFit(name=name, values={}, n_params=1, sims=[name], criterion=criterion,
                    explained=True, pinned=[], calibration=_calibration(gain_z))


def _run(monkeypatch, own_gain_z=-1.65, cal_gain_z=-1.33, loads=(0.147, 0.147),
         softening_gain=56.8):
    # seed 10023 of the confusion benchmark (a softening of 11.8 MPa/K, rod plant at 1 Hz,
    # one load, sensor drift): the calibration moved the gain -1.33 spreads and the
    # search named creep (54 s), whose joint fit kept the gain down (-1.65); the softening,
    # calibrated jointly, returned every value to the description and predicted the
    # held-out part decisively better (56.8 against 33.3)
    fits = {'creep': _fit('creep', 33.3, own_gain_z), SOFTENING: _fit(SOFTENING,
                                                                      softening_gain, 0.11)}
    asked = []

    def fake_calibrations(calibrate_with, problems, nominals, cal, candidates, groups):
        names = [' + '.join(c.name for c in group) for group in groups]
        asked.extend(names)
        return [fits[n] for n in names]

    monkeypatch.setattr(rivals_module, 'joint_calibrations', fake_calibrations)
    monkeypatch.setattr(rivals_module, 'lowers_heldout_rms', lambda problems, sims, rmse: True)
    monkeypatch.setattr(rivals_module, 'rival_experiment_notes', lambda named, rivals: [
        rival_note(f'{named.name} and {r.name} are rivals', named, r) for r in rivals
        if r.criterion >= named.criterion - 10.0])
    problem = SimpleNamespace(record=SimpleNamespace(load=np.asarray(loads)))
    taken, notes = family_rivals(None, [problem], [None], _calibration(cal_gain_z),
                                 CANDIDATES, 'creep', {})
    return taken, notes, asked


def test_an_effect_that_keeps_the_gain_down_on_one_load_gives_way_to_a_softening(monkeypatch):
    taken, notes, asked = _run(monkeypatch)
    assert asked == ['creep', SOFTENING]
    assert taken.name == SOFTENING
    assert notes[0].startswith('creep was named by the search; calibrated jointly')
    assert 'modulus_softening (penalised held-out gain 56.8) against 33.3 for creep: '\
           'modulus_softening is named' in notes[0]


def test_a_softening_as_good_is_an_open_rival_of_the_named_effect(monkeypatch):
    taken, notes, asked = _run(monkeypatch, softening_gain=40.0)
    assert taken is None and asked == ['creep', SOFTENING]
    assert undecided_rivals(['creep'], notes) == {'creep': [SOFTENING]}


def test_no_softening_is_tried_where_the_gain_says_nothing_of_one(monkeypatch):
    # the named effect's own fit returned the gain: it explained the move
    taken, notes, asked = _run(monkeypatch, own_gain_z=-0.2)
    assert asked == ['creep'] and taken is None and notes == []
    # the calibration barely moved the gain, or moved it up: no fit at all
    for gain_z in (-0.8, 1.5):
        assert _run(monkeypatch, cal_gain_z=gain_z)[2] == []
    # two loads: the softening's share of the stroke scales with the force, the gain's
    # does not, so the calibration cannot take one up as the other
    assert _run(monkeypatch, loads=(0.147, 0.392))[2] == []


def test_a_rival_within_the_margin_on_the_figure_that_chose_is_left_open(monkeypatch):
    # seed 9622 (a softening of 11.6 MPa/K, cst plant at 2 Hz, one load, no thermometer):
    # the joint stage took an ambient offset of -8.5 K (gain 115.4 less 14.3 for the room
    # it moves = 101.1) over the softening (93.6, moving nothing described): 7.5 apart on
    # the figure that chose, 21.8 on the gain alone
    from tca_ros.diagnosis import rivals
    from tca_ros.diagnosis.joint_text import joint_notes
    monkeypatch.setattr(rivals, 'rival_experiment', lambda named, rival: SimpleNamespace(
        sentence=lambda: 'a step at another load separates them'))

    def fit(name, criterion, cost):
        return JointFit(name=name, values={}, n_params=1, sims=[name], criterion=criterion,
                        explained=True, pinned=[], cost=cost)

    offset = fit('ambient_offset', 115.4, 14.3)
    notes = joint_notes(offset, [fit(SOFTENING, 93.6, 0.0)], [])
    assert 'ambient_offset and modulus_softening are rivals' in notes[-1]
    assert undecided_rivals(['ambient_offset'], notes) == {'ambient_offset': [SOFTENING]}
    # decisively below on that figure (90.0 against 101.1): told apart, no experiment
    notes = joint_notes(offset, [fit(SOFTENING, 90.0, 0.0)], [])
    assert not any('are rivals' in n for n in notes)
    assert undecided_rivals(['ambient_offset'], notes) == {}
