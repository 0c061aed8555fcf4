"""The docs' generated tables are what bench/make_docs_tables.py writes from the code."""
import importlib.util
import pathlib

import pytest

from tca_ros.calibration.candidates import RECALIBRATION
from tca_ros.model.effects import CATALOGUE

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location('make_docs_tables',
                                                  ROOT / 'bench' / 'make_docs_tables.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


TABLES = _script()


@pytest.mark.parametrize('rel', TABLES.DOCS)
def test_the_generated_tables_of_a_doc_match_the_code(rel):
    text = (ROOT / rel).read_text(encoding='utf-8')
    assert TABLES.blocks(text), f'{rel}: no generated block'
    assert TABLES.render(text, rel) == text, (
        f'{rel}: a generated table differs from the code; run '
        '`python bench/make_docs_tables.py` and commit the result')


def test_the_diagnosis_page_holds_the_catalogue_table():
    text = (ROOT / 'docs' / 'diagnosis.md').read_text(encoding='utf-8')
    assert 'catalogue' in TABLES.blocks(text)
    body = text.split('<!-- BEGIN GENERATED: catalogue')[1].split('<!-- END GENERATED')[0]
    for name, dotted_names in CATALOGUE.items():
        assert f'| `{name}`' in body, name
        for dotted in dotted_names:
            assert f'`{dotted}`' in body, dotted
    method = (ROOT / 'docs' / 'diagnosis_method.md').read_text(encoding='utf-8')
    for dotted in RECALIBRATION:
        assert f'`{dotted}`' in method, dotted


def test_a_stale_table_is_found_and_rewritten():
    text = (ROOT / 'docs' / 'diagnosis.md').read_text(encoding='utf-8')
    row = next(line for line in text.splitlines() if line.startswith('| `friction`'))
    stale = text.replace(row, row.replace('0-0.1 N', '0-0.2 N'))
    assert stale != text
    assert TABLES.render(stale) == text


def test_a_catalogue_effect_without_a_relation_is_named(monkeypatch):
    monkeypatch.setitem(CATALOGUE, 'lonely_stroke', ('effects.sensor_lag',))
    with pytest.raises(KeyError, match='lonely_stroke'):
        TABLES.catalogue_table()


def test_an_unknown_block_is_named():
    text = '<!-- BEGIN GENERATED: nonsense -->\nx\n<!-- END GENERATED: nonsense -->\n'
    with pytest.raises(KeyError, match="doc.md: unknown generated block 'nonsense'"):
        TABLES.render(text, 'doc.md')


def test_check_mode_passes_on_the_committed_docs():
    assert TABLES.main(['--check']) == 0


@pytest.mark.slow
def test_the_example_blocks_show_what_tca_sim_diagnose_prints_today():
    # runs the two example commands (about 25 s of CPU): the docs' example is the
    # command's output verbatim but for its run time (s)
    text = (ROOT / 'docs' / 'diagnosis.md').read_text(encoding='utf-8')
    assert {'example', 'example-uncalibrated'} <= set(TABLES.blocks(text))
    assert TABLES.render(text, 'docs/diagnosis.md', examples=True) == text, (
        'docs/diagnosis.md: the example differs from what tca_sim diagnose prints; run '
        '`python bench/make_docs_tables.py --examples` and commit the result')


def test_only_the_run_time_of_an_example_may_differ():
    old = 'effects found: none\n186 simulations, 20.3 s\n'
    assert TABLES.same_but_run_time(old, old.replace('20.3 s', '37.9 s'))
    assert not TABLES.same_but_run_time(old, old.replace('186', '187'))
    assert not TABLES.same_but_run_time(old, old.replace('none', 'creep'))
