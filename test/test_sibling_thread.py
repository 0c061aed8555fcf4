"""Another muscle of one thread, described with the material its calibration measured (C10)."""
import dataclasses
import io

import numpy as np
import pytest

from tca_ros.calibration.calibration import calibrate
from tca_ros.calibration.calibration_parameters import expansion_zero
from tca_ros.calibration.posterior import calibrated_uncertainty, posterior_of
from tca_ros.calibration.predictions import full_nrmse
from tca_ros.cli.main import main
from tca_ros.model.muscle import describe_muscle, MuscleSpec
from tca_ros.model.muscle_sibling import describe_from_sibling, SIBLING_FLOOR
from tca_ros.params.files import dump_params, load_params
from tca_ros.params.thread_presets import load_thread_presets
from tca_ros.synthetic.realistic import bench_record

THREAD = 'nylon66_silver'
WIDE = MuscleSpec(thread=THREAD, thread_diameter=0.45e-3, coil='mandrel', mandrel_diameter=0.8e-3,
                  pitch_angle_deg=22.5, natural_length=0.05, resistance=13.3, mass=0.02,
                  model='cst')
NARROW = dataclasses.replace(WIDE, mandrel_diameter=0.51e-3, resistance=12.0)
#: the real thread differs from the preset: a flatter Gamma(T) (T_z -15 degC, c1 = -2 c2
#: T_z), 1.6x the untwist, 0.8x the moduli
TRUE_THREAD = {'fiber.untwist_gain': 1.6}


def _truth(spec):
    params = describe_muscle(spec, load_thread_presets()).params
    c2, _, c0 = params.fiber.gamma_coefficients
    return params.with_values(**TRUE_THREAD, **{
        'fiber.gamma_coefficients': [c2, 2.0 * c2 * 15.0, c0],
        'moduli.youngs_modulus': 0.8 * params.moduli.youngs_modulus,
        'moduli.shear_modulus': 0.8 * params.moduli.shear_modulus})


@pytest.mark.slow
def test_a_sibling_s_calibrated_thread_predicts_another_muscle_s_other_power_better():
    rng = np.random.default_rng(4)
    wide = [bench_record(_truth(WIDE), w, 0.02, rng, drift=0.0) for w in (0.3, 0.6)]
    narrow = [bench_record(_truth(NARROW), w, 0.02, rng, drift=0.0) for w in (0.3, 0.6)]
    cal = calibrate(wide, describe_muscle(WIDE, load_thread_presets()).params, model='cst',
                    check=False)
    sibling = calibrated_uncertainty(cal.params, posterior_of(cal))
    described, warnings = describe_from_sibling(NARROW, load_thread_presets(), sibling)
    from_sibling = described.params
    from_preset = describe_muscle(NARROW, load_thread_presets()).params
    assert warnings == []
    errors = {}
    for name, start in (('preset', from_preset), ('sibling', from_sibling)):
        # one power level to train on: the other power is what the thread must carry
        trained = calibrate(narrow[:1], start, model='cst', check=False)
        errors[name] = full_nrmse(trained.params, narrow[1:], 'cst')[0]
    assert errors['sibling'] < 0.7 * errors['preset'], errors
    assert expansion_zero(from_sibling.fiber) == pytest.approx(expansion_zero(sibling.fiber))


def test_config_new_takes_the_thread_and_its_uncertainty_from_a_calibrated_file(tmp_path, capsys):
    sibling = _truth(WIDE).with_values(**{'uncertainty.heat_loss': 0.05,
                                          'uncertainty.actuation_gain': 0.4,
                                          'uncertainty.expansion_zero_temperature': 3.0})
    dump_params(sibling, tmp_path / 'cal.yaml')
    args = ['config', 'new', '--thread', THREAD, '--thread-diameter', '0.45e-3', '--coil',
            'mandrel', '--mandrel-diameter', '0.51e-3', '--pitch-angle', '22.5',
            '--natural-length', '0.05', '--resistance', '12', '--mass', '0.02', '--model',
            'cst', '--material-from', str(tmp_path / 'cal.yaml')]
    assert main(args + ['--out', str(tmp_path / 'b.yaml')], out=io.StringIO()) == 0
    b = load_params(str(tmp_path / 'b.yaml'))
    assert b.fiber.untwist_gain == pytest.approx(1.6)
    assert b.moduli.youngs_modulus == pytest.approx(sibling.moduli.youngs_modulus)
    assert list(b.fiber.gamma_coefficients) == pytest.approx(sibling.fiber.gamma_coefficients)
    assert b.coil.radius != sibling.coil.radius  # its own geometry
    # the sibling's uncertainty, never below what two muscles of one make differ by
    assert b.uncertainty.heat_loss == pytest.approx(SIBLING_FLOOR['relative'])
    assert b.uncertainty.actuation_gain == pytest.approx(0.4)
    assert b.uncertainty.expansion_zero_temperature == \
        pytest.approx(SIBLING_FLOOR['expansion_zero_temperature'])
    assert 'Material from the calibrated muscle' in (tmp_path / 'b.yaml').read_text()
    assert 'warning' not in capsys.readouterr().err
    # a thread of another thickness: said, not refused
    assert main(args[:5] + ['0.7e-3'] + args[6:] + ['--out', str(tmp_path / 'c.yaml')],
                out=io.StringIO()) == 0
    assert "the calibrated muscle's thread is 0.45 mm thick" in capsys.readouterr().err
    # a file that is not there: one line, status 2
    bad = args[:-1] + [str(tmp_path / 'missing.yaml'), '--out', str(tmp_path / 'd.yaml')]
    assert main(bad, out=io.StringIO()) == 2
    assert '--material-from' in capsys.readouterr().err
