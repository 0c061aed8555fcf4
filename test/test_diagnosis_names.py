"""One name per parameter and the muscle named by its file, in diagnose and calibrate.

Issue 25, item 5: `actuation_gain 3.25` from calibrate reappeared as
`untwist_gain=5.21` in diagnose, and a user's muscle was called by the
shipped config its record's header names.
"""
import pathlib
import re
import shutil
import types

import pytest

import tca_ros
from tca_ros.calibration.physical_priors import Plausibility
from tca_ros.cli.main import main
from tca_ros.diagnosis import diagnose, format_summary
from tca_ros.diagnosis.parameter_names import format_nominal, nominal_value, \
    plausibility_lines
from tca_ros.model.thermal import fiber_mass
from tca_ros.params.files import load_params

EXAMPLE = pathlib.Path(tca_ros.__file__).parent / 'data' / 'example_recording.csv'
CONFIG = pathlib.Path(tca_ros.__file__).parent.parent / 'config' / 'free_stroke.yaml'
SHORT_S = 120.0  # s of the example kept for the fast diagnoses here
DOTTED_NOMINAL = ('untwist_gain', 'specific_heat', 'fiber.', 'thermal.', 'dynamics.')


def _short_record(tmp_path):
    """Write the example's first SHORT_S seconds (creep and power loss hidden in it)."""
    lines = EXAMPLE.read_text().splitlines()
    head = [s for s in lines if s.startswith('#')]
    body = [s for s in lines if not s.startswith('#')]
    kept = [body[0]] + [s for s in body[1:] if float(s.split(',')[0]) <= SHORT_S]
    path = tmp_path / 'my_record.csv'
    path.write_text('\n'.join(head + kept) + '\n')
    return str(path)


def test_nominal_entries_print_as_the_calibration_names_them():
    params = load_params('free_stroke')
    assert format_nominal('fiber.untwist_gain', 3.25, params) == 'actuation_gain=3.25'
    assert format_nominal('dynamics.damping', 0.5, params) == 'damping=0.5 N s/m'
    label, value, unit = nominal_value('fiber.specific_heat', 961.0, params)
    assert (label, unit) == ('heat_capacity', 'J/K')
    assert abs(value - 961.0 * fiber_mass(params.fiber)) < 1e-12
    assert format_nominal('effects.creep_compliance', 5e-3, params) is None


def test_a_shift_beyond_two_prior_spreads_is_a_finding_with_what_it_can_stand_for():
    def row(name, z):
        return Plausibility(name, 'W/K', 0.02, 0.0133, z, 0.0136, '', 0.004, 0.04, False)
    from tca_ros.calibration.physical_priors import stands_for
    rows = [row('heat_loss', 2.1), row('stiffness_scale', 1.9)]
    cal = types.SimpleNamespace(  # Calibration.findings: the shifted rows, tau moved
        plausibility=lambda: rows, derived=lambda: {}, time_constant_z=lambda: 1.5,
        findings=lambda: [(r.name, r.z, stands_for(r.name, r.z, 1.5)) for r in rows
                          if r.shifted])
    lines = plausibility_lines(cal)
    assert lines[0].rstrip().endswith('SHIFTED') and 'SHIFTED' not in lines[1]
    findings = [s for s in lines if s.startswith('finding:')]
    assert len(findings) == 1 and 'heat_loss moved +2.1 prior spreads' in findings[0]
    assert 'radiation' in findings[0] and 'nonlinear_convection' in findings[0]
    assert 'more air flow than the description assumes' in findings[0]  # tau moved too


def test_calibrate_and_diagnose_print_one_name_and_value_per_parameter(tmp_path, capsys):
    record = _short_record(tmp_path)
    muscle = tmp_path / 'my_muscle.yaml'
    shutil.copy(CONFIG, muscle)
    calibrated = tmp_path / 'my_muscle_cal.yaml'
    assert main(['calibrate', record, '--config', str(muscle), '--model', 'cst', '--quiet',
                 '--out', str(calibrated)]) == 0
    printed = capsys.readouterr().out.split('plausibility:')[0]  # parameter, start, value
    values = dict(re.findall(r'^(actuation_gain|heat_capacity|heat_loss|damping)\s+\S+\s+(\S+)',
                             printed, flags=re.M))
    assert set(values) == {'actuation_gain', 'heat_capacity', 'heat_loss', 'damping'}, printed
    result = diagnose(record, str(muscle), model='cst', progress=False,
                      calibrated=str(calibrated))
    summary = format_summary(result)
    print(summary)
    line = next(s for s in summary.splitlines() if s.startswith('nominal parameters from'))
    for name, value in values.items():  # the value calibrate printed, under its name
        assert f'{name} {value}' in line, (name, value, line)
    assert f'config {muscle}, nominal parameters from {calibrated}' in summary
    assert "'# tca:' header" not in summary and 'free_stroke' not in summary
    candidates = summary.split('candidates, each alone')[1].split('verdict:')[0]
    assert 'actuation_gain=' in candidates
    for dotted in DOTTED_NOMINAL:
        assert dotted not in candidates, dotted


@pytest.mark.slow
def test_a_diagnosis_names_its_calibration_as_calibrate_does(tmp_path):
    record = _short_record(tmp_path)
    report = tmp_path / 'report'
    result = diagnose(record, None, model='cst', progress=False, report_dir=str(report))
    summary = format_summary(result)
    print(summary)
    assert "config free_stroke (from the record's '# tca:' header)" in summary
    estimates = result.calibration.report.estimates
    for name, est in estimates.items():  # calibrate's rows: name and value (4 digits)
        assert re.search(rf'^  {name}\s+{re.escape(f"{est.value:.4g}")} ', summary,
                         flags=re.M), name
    for dotted in DOTTED_NOMINAL:
        assert dotted not in summary.split('effects found')[0].split('candidates')[1], dotted
    text = (report / 'report.md').read_text()
    assert "(from the record's '# tca:' header)" in text and '## Nominal parameters' in text
    assert 'heat_capacity' in text and '- `fiber.specific_heat` =' not in text


def test_the_derived_steady_rise_says_the_power_loss_it_amounts_to():
    def cal(rise, tau=3.02):
        derived = {'thermal_time_constant': types.SimpleNamespace(value=tau, prior=3.0),
                   'steady_rise': types.SimpleNamespace(value=rise, prior=75.0)}
        return types.SimpleNamespace(plausibility=lambda: [], derived=lambda: derived,
                                     findings=lambda: [])
    line, = plausibility_lines(cal(61.5))  # the example's: 18.3 % of the power lost
    assert 'steady rise 61.5 K/W (0.82 x)' in line and 'a power loss of 18 %' in line
    assert 'thermal time constant 3.02 s (1.01 x the description)' in line
    line, = plausibility_lines(cal(80.0))  # a higher rise: no power loss can do that
    assert 'power loss' not in line
    line, = plausibility_lines(cal(27.0, tau=1.08))  # a fan: tau fell with the rise
    assert 'power loss' not in line and 'more heat is carried away' in line
