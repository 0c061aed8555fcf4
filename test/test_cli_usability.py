"""`tca_sim` as a new user meets it (issue 27, item 6): errors, help, version, warnings.

Usage errors name the subcommand (exit status 2), flags are never abbreviated, every
subcommand's help has a description, one default per option and a runnable example,
``--version`` says the package's version, ``statics`` warns past the model's
temperature range, and ``simulate`` keeps the rows simulated before the thread
breaks or melts (exit status 3).
"""
import argparse
import io
import os
import pathlib
import re
import shlex
import subprocess
import sys

import numpy as np
import pytest

from tca_ros.cli.common import EXIT_EVENT, package_version
from tca_ros.cli.main import build_parser, main

ROOT = pathlib.Path(__file__).resolve().parents[1]


def run(argv, capsys):
    """Return (status, stdout, stderr) of one in-process `tca_sim` run."""
    out = io.StringIO()
    try:
        code = main(argv, out=out)
    except SystemExit as exc:  # argparse: usage errors, --help, --version
        code = exc.code
    captured = capsys.readouterr()
    return code, out.getvalue() + captured.out, captured.err


def parsers(parser=None, path=()):
    """Yield (command words, parser) for tca_sim and every subcommand below it."""
    parser = parser or build_parser()
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from parsers(child, path + (name,))


SUBCOMMANDS = [path for path, _ in parsers() if path]


# -- errors name the subcommand ---------------------------------------------------
def test_an_unknown_flag_is_refused_by_its_subcommand_in_a_real_process(tmp_path):
    profile = tmp_path / 'p.csv'
    profile.write_text('time,power\n0,1\n1,0\n')
    proc = subprocess.run([sys.executable, '-m', 'tca_ros.cli.main', 'simulate', '--input',
                           str(profile), '--masss', '1'], capture_output=True, text=True,
                          env={**os.environ, 'PYTHONPATH': str(ROOT)}, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ''
    assert proc.stderr == 'tca_sim simulate: error: unrecognized arguments: --masss\n'


@pytest.mark.parametrize('argv, prog', [
    (['statics', '--tmax', '100', 'extra'], 'tca_sim statics'),
    (['config', 'new', '--out', 'x.yaml', '--bogus'], 'tca_sim config new'),
    (['score', '--tasks', 'step_up', '--namespce', '/a'], 'tca_sim score'),
])
def test_unrecognized_arguments_name_the_subcommand(capsys, argv, prog):
    code, out, err = run(argv, capsys)
    assert code == 2 and out == ''
    assert err.startswith(f'{prog}: error: unrecognized arguments: ') and err.count('\n') == 1


def test_config_without_its_subcommand_lists_the_choices_in_words(capsys):
    code, _, err = run(['config'], capsys)
    assert code == 2 and err.count('\n') == 1
    assert err.startswith('tca_sim config: error: missing the subcommand: choose one of new '
                          '(write a params file')
    assert 'config_command' not in err and 'tca_sim config NAME --help' in err


def test_no_command_lists_the_commands(capsys):
    code, _, err = run([], capsys)
    assert code == 2 and err.startswith('tca_sim: error: missing the command: choose one of ')
    for name in ('statics', 'simulate', 'diagnose', 'calibrate', 'score', 'config'):
        assert name in err


def test_a_failure_inside_config_new_names_config_new(tmp_path, capsys):
    target = tmp_path / 'exists.yaml'
    target.write_text('x: 1\n')
    code, _, err = run(['config', 'new', '--out', str(target)], capsys)
    assert code == 2 and err.startswith('tca_sim config new: error: --out = ')


# -- no abbreviations ---------------------------------------------------------------
def test_every_parser_refuses_abbreviations():
    for path, parser in parsers():
        assert parser.allow_abbrev is False, path


@pytest.mark.parametrize('argv', [
    ['statics', '--mas', '0.01'],
    ['statics', '--tma', '100'],
    ['linearize', '--pow', '1'],
    ['score', '--dur', '1'],
])
def test_an_abbreviated_flag_is_unrecognized_not_guessed(capsys, argv):
    code, out, err = run(argv, capsys)
    assert code == 2 and out == ''
    # named before the missing required --power of linearize
    assert err == f'tca_sim {argv[0]}: error: unrecognized arguments: {argv[1]}\n', err


def _documented_options():
    """Return {command words: set of flags} of docs/cli.md's 'Every option' list."""
    section = (ROOT / 'docs' / 'cli.md').read_text().split('## Every option', 1)[1]
    section = section.split('\n## ', 1)[0]
    documented = {}
    for item in re.split(r'\n- ', section)[1:]:
        command = re.match(r'`([a-z ]+?)(?: RECORD\.\.\.)?`:', item).group(1)
        documented[tuple(command.split())] = set(re.findall(r'`(--[a-z-]+)`', item))
    return documented


def test_docs_cli_lists_every_option_of_every_subcommand_and_no_other():
    documented = _documented_options()
    commands = {path: parser for path, parser in parsers() if path and not any(
        isinstance(a, argparse._SubParsersAction) for a in parser._actions)}
    assert set(documented) == set(commands)
    for path, parser in commands.items():
        flags = {o for a in parser._actions for o in a.option_strings
                 if o.startswith('--') and o != '--help'}
        assert documented[path] == flags, path


# -- help: description, one default per option, an example that runs -----------------
def _help(path, capsys):
    code, out, _ = run([*path, '--help'], capsys)
    assert code == 0
    return out


def _option_blocks(text):
    """Return the help text of each option (its line and the indented lines under it)."""
    body = text.split('options:', 1)[1].split('\n\n', 1)[0]
    return re.split(r'\n(?=  -)', body)


@pytest.mark.parametrize('path', SUBCOMMANDS, ids=' '.join)
def test_help_has_a_description_an_example_and_one_default_per_option(path, capsys):
    text = _help(path, capsys)
    for bad in ('(default: None)', '(default: )', '(default: False)', '(default: True)'):
        assert bad not in text, (path, bad)
    for block in _option_blocks(text):
        assert block.lower().count('default') <= 1, (path, block)
    usage_end = text.index('\n\n')
    description = text[usage_end:].strip().split('\n\n')[0]
    assert len(description) > 40 and not description.startswith(('options:', 'positional'))
    assert '\nexample' in text, path
    commands = [shlex.split(c.split(' > ')[0]) for c in _example_commands(text)]
    assert any(words[1:len(path) + 1] == list(path) for words in commands), path
    for words in commands:  # each example parses: its flags exist, its values fit
        if words[0] == 'tca_sim':
            build_parser().parse_args(words[1:])


def _example_commands(text):
    """Return the example command lines of a help text (continuations joined)."""
    epilog = text[text.index('\nexample'):]
    lines = [line.strip() for line in epilog.splitlines() if line.startswith('  ')]
    joined = ' '.join(lines).replace('\\ ', '')
    return [c.strip() for c in re.split(r'(?=\b(?:tca_sim|printf) )', joined) if c.strip()]


def test_the_quick_examples_run_as_printed(tmp_path, capsys, monkeypatch):
    """Run the examples of statics, simulate, config new, linearize and score verbatim."""
    monkeypatch.chdir(tmp_path)
    examples = {path: _example_commands(_help(path, capsys)) for path in SUBCOMMANDS}
    (tmp_path / 'step.csv').write_text('time,power\n0,1\n20,0\n60,0\n')  # printf's file
    assert "printf 'time,power\\n0,1\\n20,0\\n60,0\\n' > step.csv" in examples[('simulate',)]
    for path in [('statics',), ('simulate',), ('config', 'new'), ('linearize',), ('score',)]:
        for command in examples[path]:
            if not command.startswith('tca_sim'):
                continue
            words = shlex.split(command.split(' > ')[0])
            code, out, err = run(words[1:], capsys)
            assert code == 0, (command, err)
            assert out.strip(), command
    assert (tmp_path / 'my_tca.yaml').is_file() and (tmp_path / 'out' / 'score').is_dir()


def test_the_record_examples_name_a_shipped_file(capsys):
    for path in [('diagnose',), ('calibrate',)]:
        for command in _example_commands(_help(path, capsys)):
            shipped = [w for w in shlex.split(command) if w.endswith('.csv')]
            assert shipped and all((ROOT / w).is_file() for w in shipped), command


def test_version_is_the_package_version(capsys):
    code, out, _ = run(['--version'], capsys)
    assert code == 0
    setup = (ROOT / 'setup.py').read_text()
    version = re.search(r"version='([^']+)'", setup).group(1)
    assert package_version() == version
    assert out == f'tca_sim {version} (tca_ros)\n'


# -- range warnings -------------------------------------------------------------------
def test_statics_past_the_melt_warns_once_and_still_prints(capsys):
    code, out, err = run(['statics', '--model', 'cst', '--tmax', '400', '--tstep', '75'],
                         capsys)
    assert code == 0
    rows = out.strip().splitlines()
    assert rows[0] == 'temperature,displacement'
    assert [float(r.split(',')[0]) for r in rows[1:]] == [25, 100, 175, 250, 325, 400]
    assert err.count('\n') == 1 and err.startswith('tca_sim statics: warning: ')
    assert '--tmax = 400 degC' in err and '260 degC' in err and 'range' in err


def test_statics_inside_the_range_says_nothing(capsys):
    code, out, err = run(['statics', '--model', 'cst', '--tmax', '250', '--tstep', '75'],
                         capsys)
    assert code == 0 and err == '' and len(out.strip().splitlines()) == 5


def test_statics_far_below_ambient_warns_naming_tmin(capsys):
    code, _, err = run(['statics', '--model', 'cst', '--tmin', '-10', '--tmax', '60',
                        '--tstep', '35'], capsys)
    assert code == 0 and err.count('\n') == 1 and '--tmin = -10 degC' in err


# -- partial output on a physical event ------------------------------------------------
def _rows(text):
    lines = text.strip().splitlines()
    return lines[0], np.array([[float(v) for v in line.split(',')] for line in lines[1:]])


def _profile(tmp_path, text):
    path = tmp_path / 'profile.csv'
    path.write_text(text)
    return str(path)


def test_a_load_that_breaks_the_thread_keeps_the_rows_before_it(tmp_path, capsys):
    profile = _profile(tmp_path, 'time,power,load\n0,0,0.3\n1,0,2.5\n2,0,2.5\n')
    code, out, err = run(['simulate', '--model', 'cst', '--input', profile, '--rate', '10'],
                         capsys)
    assert code == EXIT_EVENT == 3
    header, rows = _rows(out)
    assert header == 'time,power,load,displacement,temperature,resistance'
    # the 2.5 N load from 1 s overshoots past 2.354 N within the next 0.1 s
    np.testing.assert_allclose(rows[:, 0], np.arange(11) / 10.0)
    assert err.count('\n') == 1 and err.startswith('tca_sim simulate: error: tension ')
    assert 'exceeds fiber.break_force 2.354 N' in err and 'the 11 rows before it' in err
    # the rows are those of the run cut before the event
    cut = _profile(tmp_path, 'time,power,load\n0,0,0.3\n1,0,2.5\n')
    code, whole, _ = run(['simulate', '--model', 'cst', '--input', cut, '--rate', '10'],
                         capsys)
    assert code == 0 and whole == out


def test_a_load_that_breaks_the_thread_at_once_writes_the_header_only(tmp_path, capsys):
    profile = _profile(tmp_path, 'time,power,load\n0,0,3\n1,0,3\n')
    code, out, err = run(['simulate', '--model', 'cst', '--input', profile], capsys)
    assert code == 3 and out == 'time,power,load,displacement,temperature,resistance\n'
    assert 'no rows written' in err and err.count('\n') == 1


@pytest.mark.parametrize('model', ['cst', 'rod'])
def test_heating_to_the_melt_ends_the_run_with_the_rows_before_it(tmp_path, capsys, model):
    profile = _profile(tmp_path, 'time,power,load\n0,8,0.3\n30,8,0.3\n')
    code, out, err = run(['simulate', '--model', model, '--input', profile, '--rate', '10'],
                         capsys)
    assert code == 3, err
    _, rows = _rows(out)
    assert 10 <= len(rows) < 300 and rows[:, 4].max() < 260.0
    assert rows[-1, 4] > 200.0  # it was heating fast towards the melt
    assert err.count('\n') == 1 and 'the thread melts' in err and '260 degC' in err


def test_the_partial_result_is_the_prefix_of_the_run(free_stroke):
    from tca_ros.model.limits import ThreadBreakError
    from tca_ros.model.simulation import simulate
    t = np.arange(0.0, 3.0001, 0.05)
    power = np.zeros_like(t)
    load = np.where(t < 1.0, 0.3, 2.5)
    with pytest.raises(ThreadBreakError) as info:
        simulate(free_stroke, t, power, load, model='cst')
    partial = info.value.partial
    n = partial.time.size
    assert 0 < n < t.size and partial.displacement.size == n
    whole = simulate(free_stroke, t[:n], power[:n], load[:n], model='cst')
    np.testing.assert_array_equal(partial.displacement, whole.displacement)
    np.testing.assert_array_equal(partial.temperature, whole.temperature)
