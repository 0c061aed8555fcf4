"""The cheap paths of the diagnosis give what the expensive ones gave (issue 9, speed).

* ``simulate`` keeps its physics step on a uniform grid read back from text
  (intervals differing by ~1e-12), instead of re-planning the substeps at every
  sample, and still re-plans on a grid that is really non-uniform.
* FitProblem runs the full dynamics on the coarse grid only where the coil stop
  moves from the base's (a fit or candidate that moves it); a stop held at the
  base's value runs on the quasi-static reduction, corrected at that base.
"""
import math

import numpy as np
import pytest

from tca_ros.calibration.candidates import build_candidates
from tca_ros.diagnosis.candidate_fit import fit_candidate, screen
from tca_ros.diagnosis.fitting import FitProblem, STOP
from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.simulation import simulate
from tca_ros.params.files import load_params
from tca_ros.synthetic.generator import make_synthetic_record


@pytest.fixture(scope='module')
def stepper():
    return load_params('free_stroke', **{'dynamics.mass': 0.02, 'dynamics.load': 0.2})


def _count_set_dt(monkeypatch):
    calls = []
    original = TcaSimulator.set_dt

    def spy(self, dt):
        calls.append(dt)
        return original(self, dt)
    monkeypatch.setattr(TcaSimulator, 'set_dt', spy)
    return calls


def test_text_rounded_grid_keeps_one_physics_step(monkeypatch, stepper):
    exact = np.arange(2001) / 100.0
    # late in a record, as a CSV reader gets it: the intervals vary by ~1e-12 relative
    rounded = np.array([float(f'{200.0 + t:.4f}') for t in exact])
    assert np.ptp(np.diff(rounded)) > 1e-12 * 0.01  # the old tolerance re-planned these
    power = np.where((exact > 2.0) & (exact < 12.0), 0.4, 0.0)
    calls = _count_set_dt(monkeypatch)
    read = simulate(stepper, rounded, power, model='cst', physics_rate=200.0)
    assert calls == []
    reference = simulate(stepper, exact, power, model='cst', physics_rate=200.0)
    assert np.max(np.abs(read.displacement - reference.displacement)) < 1e-12


def test_non_uniform_grid_still_replans_the_step(monkeypatch, stepper):
    # 10 ms, then 13 ms intervals: three physics steps of 13/3 ms each instead of 5 ms
    time = np.concatenate((np.arange(101) / 100.0, 1.0 + 0.013 * np.arange(1, 51)))
    calls = _count_set_dt(monkeypatch)
    simulate(stepper, time, np.full(time.size, 0.3), model='cst', physics_rate=200.0)
    assert calls and calls[0] == pytest.approx(0.013 / 3.0)


@pytest.fixture(scope='module')
def contact_problem():
    """A short cst record and a base whose coil stop binds in it."""
    synth = make_synthetic_record(4, effects=('coil_contact',), duration=60.0,
                                  sample_rate=20.0)
    record = synth.record
    params = load_params('free_stroke', model='cst').with_values(**{
        'dynamics.mass': record.mass, 'dynamics.load': float(record.load[0])})
    problem = FitProblem(record, params, model='cst')
    stop = synth.values[STOP]
    problem.set_base({STOP: stop})
    return problem, params, stop


def _kinds(monkeypatch, problem):
    kinds = []
    original = FitProblem._coarse_simulation

    def spy(self, params, end, kind=None):
        out = original(self, params, end, kind)
        kinds.append(out[0])
        return out
    monkeypatch.setattr(FitProblem, '_coarse_simulation', spy)
    return kinds


def test_base_with_a_stop_is_reproduced_by_both_kinds(contact_problem):
    problem, _, stop = contact_problem
    full = problem.simulate_full({STOP: stop})
    assert set(k for k, _ in problem.correction) == {'full', 'reduced'}
    for kind in ('full', 'reduced'):
        correction = problem.correction[(kind, stop)]
        _, coarse = problem._coarse_simulation(problem.parameters({STOP: stop}), problem.m,
                                               kind)
        predicted = coarse.displacement + correction['displacement']
        assert np.max(np.abs(predicted - full.displacement[problem.index])) < 1e-12


def test_stop_held_at_the_base_runs_reduced_a_moving_stop_full(monkeypatch, contact_problem):
    problem, params, stop = contact_problem
    kinds = _kinds(monkeypatch, problem)
    candidates = {c.name: c for c in build_candidates(params, 'cst', problem.record.load[0],
                                                      1e-3)}
    screen(problem, candidates['ambient_offset'])
    assert kinds and set(kinds) == {'reduced'}
    del kinds[:]
    # a refit that moves the stop: every evaluation on the full dynamics, so the
    # finite differences compare one kind of simulation with itself
    contact = candidates['coil_contact']
    fit = fit_candidate(problem, candidates['ambient_offset'], (0.5,), free=contact.spaces,
                        max_nfev=2)
    assert kinds and set(kinds) == {'full'}
    assert fit.params[STOP] != stop and not problem.stop_moves
    del kinds[:]
    problem.train_residuals({STOP: stop + 0.5})  # a candidate that moves the stop
    assert kinds == ['full']
    assert math.isfinite(problem.heldout({STOP: stop})[0])
