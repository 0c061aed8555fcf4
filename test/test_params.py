"""Parameter files: load, validate, round-trip."""
import math

import pytest

from tca_ros.model.params_schema import ParameterError, SCHEMA
from tca_ros.model.tca_params import to_flat_dict
from tca_ros.params.config_search import shipped_configs
from tca_ros.params.files import dump_params, load_params


def test_shipped_configs_load_and_match_tables(free_stroke, self_coiled):
    assert {'free_stroke', 'self_coiled', 'conical'} <= set(shipped_configs())
    assert free_stroke.coil.radius == pytest.approx(0.408e-3)
    assert math.degrees(free_stroke.coil.pitch_angle) == pytest.approx(22.42)
    assert self_coiled.coil.radius == pytest.approx(0.227e-3)
    conical = load_params('conical')
    assert conical.coil.shape == 'conical' and conical.fiber.length == pytest.approx(0.145)


def test_round_trip_through_yaml(tmp_path, free_stroke):
    path = tmp_path / 'p.yaml'
    dump_params(free_stroke, path, header='round trip')
    again = load_params(str(path))
    assert to_flat_dict(again) == to_flat_dict(free_stroke)


def _write(tmp_path, body):
    path = tmp_path / 'bad.yaml'
    path.write_text('/**/tca:\n  ros__parameters:\n' + body)
    return str(path)


@pytest.mark.parametrize('body, needle', [
    ('    fiber:\n      radius: -1.0\n', "'fiber.radius' = -1.0"),
    ('    fiber:\n      radius: .nan\n', "'fiber.radius' = nan"),
    ('    model: spring\n', "'model' = 'spring': must be one of rod, cst, love"),
    ('    coil:\n      contact: 3\n', "'coil.contact' = 3: must be true or false"),
    ('    moduli:\n      load_coefficients: [1.0, 2.0]\n', "'moduli.load_coefficients'"),
    ('    coil:\n      min_pitch_angle_deg: 30.0\n', 'must be below coil.pitch_angle_deg'),
    ('    dynamics:\n      masss: 1.0\n', "'dynamics.masss' = 1.0: unknown parameter"),
    ('    fiber:\n      radius: 1.2e9\n', "'fiber.radius' = '1.2e9'"),
])
def test_bad_value_gives_one_line_error_naming_it(tmp_path, body, needle):
    with pytest.raises(ParameterError) as info:
        load_params(_write(tmp_path, body))
    message = str(info.value)
    assert needle in message
    assert '\n' not in message


def test_range_message_states_allowed_range(tmp_path):
    with pytest.raises(ParameterError, match=r'\[1e-06, 0.005\] m'):
        load_params(_write(tmp_path, '    fiber:\n      radius: 1.0\n'))


def test_missing_section_and_missing_file(tmp_path):
    path = tmp_path / 'x.yaml'
    path.write_text('foo: {bar: 1}\n')
    with pytest.raises(ParameterError, match='ros__parameters'):
        load_params(str(path))
    with pytest.raises(ParameterError, match='no such file'):
        load_params('no_such_tca')


def test_every_schema_entry_documents_a_unit():
    for spec in SCHEMA:
        assert spec.unit and spec.description.endswith('.'), spec.name
