"""Regenerate the docs' tables that are read from the code, between marker comments.

A generated block in a doc starts with ``<!-- BEGIN GENERATED: NAME ... -->`` and ends
with ``<!-- END GENERATED: NAME -->``; everything between is replaced by TABLES[NAME].
The tables are read from the catalogue of effects (tca_ros.model.effects.CATALOGUE),
the parameter schema (tca_ros.model.params_schema.SCHEMA: units, defaults, ranges),
the diagnosis's search spaces (tca_ros.calibration.candidates), the synthetic
generator's ranges (tca_ros.synthetic.generator) and the joint stage's families
(tca_ros.diagnosis.rivals: FAMILIES, rivals_of). The example blocks (EXAMPLES) are what
`tca_sim diagnose` prints on the shipped example record; they take about a minute, so
only ``--examples`` runs them, and their run time line is compared without its
seconds. test/test_docs_tables.py fails when a doc's block differs from what this
script writes.

    python bench/make_docs_tables.py                       # rewrite the tables in place
    python bench/make_docs_tables.py --examples            # the examples too
    python bench/make_docs_tables.py --check [--examples]  # exit 1 naming stale docs
"""
import argparse
import contextlib
import io
import math
import os
import pathlib
import re
import sys
import tempfile

from tca_ros.calibration import candidates as cand
from tca_ros.cli.main import main as tca_sim
from tca_ros.diagnosis.rivals import FAMILIES, rivals_of
from tca_ros.model.effects import CATALOGUE
from tca_ros.model.params_schema import SPECS
from tca_ros.params.files import load_params
from tca_ros.synthetic import generator as gen

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: Docs holding generated blocks, relative to the repository root.
DOCS = ('docs/diagnosis.md', 'docs/diagnosis_method.md')
BLOCK = re.compile(r'(<!-- BEGIN GENERATED: (?P<name>[\w-]+)[^\n]*-->\n)(?P<body>.*?)'
                   r'(<!-- END GENERATED: (?P=name) -->)', re.S)

#: What each effect adds to the physics (the relation of tca_ros/model/effects.py).
RELATIONS = {
    'creep': 'Kelvin-Voigt element in series: dy_c/dt = (C F - y_c) / tau_c',
    'hysteresis': 'play operator of width w on the actuation temperature',
    'radiation': 'eps sigma A_0 (T^4 - T_inf^4) added to the heat loss of eq. (1)',
    'nonlinear_convection': 'h (|T - T_inf| / dT_ref)^n in eq. (1)',
    'modulus_softening': 'E_f falls faster with T than eq. (11) says',
    'coil_contact': 'hard stop: l >= l_t sin alpha_min (Sec. V-D1)',
    'sensor_lag': 'first-order lag of the displacement sensor',
    'ambient_offset': 'true T_inf = nominal + offset',
    'power_loss': 'heating power (1 - eta) P',
    'dead_time': "P_in(t) = P(t - d): the drive's delay",
    'second_thermal_lag': 'tau_2 dT_f/dt = T - T_f; T_f actuates, T is logged',
    'friction': 'Coulomb force F_k on the free end in eq. (18) (Karnopp stick band; '
                'a play operator on y when massless)',
}
#: Where each effect's form and magnitudes come from.
LITERATURE = {
    'creep': 'Kianzad et al., SPIE 9430 (2015); Sun & Zhao, T-RO 2022, Sec. VI',
    'hysteresis': 'Zhang, Iyer, Simeonov, Yip, IEEE RA-L 2(2) (2017)',
    'radiation': 'Masuya et al., Sens. Actuators A 267 (2017)',
    'nonlinear_convection': 'Masuya et al. (2017); laminar natural convection n = 1/4',
    'modulus_softening': 'Karami, Wu, Tadesse, IEEE/ASME T-Mech 26(1) (2021); '
                         'Demsar et al. (2010)',
    'coil_contact': 'Sun & Zhao, T-RO 2022, Sec. V-D1',
    'sensor_lag': 'laser / LVDT signal conditioning',
    'ambient_offset': 'lab practice (Table II assumes 25 degC)',
    'power_loss': 'leads, contacts, clamp conduction',
    'dead_time': 'switching and controller delays of a drive',
    'second_thermal_lag': 'core behind surface, thread behind heater',
    'friction': 'Karnopp, J. Dyn. Syst. 107 (1985); Jones & Davidson, RoboSoft 2023',
}
#: The config the coil-contact bounds are shown for (they depend on the coil).
CONTACT_CONFIG = 'free_stroke'


def number(value):
    """Return ``value`` written short: 3e7 rather than 3e+07 or 30000000."""
    text = f'{value:.3g}'
    mantissa, _, exponent = text.partition('e')
    return mantissa + ('e' + str(int(exponent)) if exponent else '')


def span(low, high, unit):
    """Return 'low-high unit' (or 'low to high unit' when a bound is negative)."""
    sep = ' to ' if low < 0 or high < 0 else '-'
    text = f'{number(low)}{sep}{number(high)}'
    return text if unit == '-' else f'{text} {unit}'


def cell(text):
    """Return ``text`` safe inside a Markdown table cell (pipes escaped)."""
    return text.replace('|', '\\|')


def _family(name):
    for family in FAMILIES:
        if name in family:
            own = [f for f in family if f != name]
            also = sorted(rivals_of(name) - set(own))  # rivals.HELD_BEHIND
            return ', '.join(own) + (f'; also {", ".join(also)}' if also else '')
    return '-'


def _generator_range(name, dotted):
    if name == 'coil_contact':
        low, high = gen.CONTACT_STROKE_FRACTION
        m_low, m_high = gen.CONTACT_MASS_RANGE_KG
        return (f'stop cuts the peak stroke to {number(100 * low)}-{number(100 * high)} % '
                f'({number(1e3 * m_low)}-{number(1e3 * m_high)} g loads)')
    if dotted not in gen.EFFECT_RANGES:  # a start state (candidates.START_STATES)
        return "not drawn: the plant's history puts it (0 at rest, an edge after a heating)"
    low, high, log = gen.EFFECT_RANGES[dotted]
    either = ', either sign' if dotted == 'effects.ambient_offset' else ''
    return span(low, high, SPECS[dotted].unit) + either + (' (log)' if log else '')


def _fit_space(name, dotted):
    if name == 'coil_contact':
        coil = load_params(CONTACT_CONFIG).coil
        low, high = math.degrees(coil.min_pitch_angle), math.degrees(coil.pitch_angle)
        fractions = ', '.join(number(100 * f) for f in cand.CONTACT_START_FRACTIONS)
        bounds = (f'nominal alpha_min to alpha* - {number(cand.CONTACT_MARGIN_DEG)} deg '
                  f'({CONTACT_CONFIG}: {span(low, high - cand.CONTACT_MARGIN_DEG, "deg")})')
        return bounds, (f'stop at {fractions} % of the nominal peak stroke, '
                        'and at the measured peak')
    space, starts = cand.effect_space(dotted)
    bounds = span(space.low, space.high, space.unit) + (' (log)' if space.log else '')
    return bounds, ', '.join(number(s) for s in starts)


def catalogue_table():
    """Return the Markdown table of the catalogue: one row per effect parameter."""
    missing = [n for n in CATALOGUE if n not in RELATIONS or n not in LITERATURE]
    if missing:
        raise KeyError(f'bench/make_docs_tables.py: no relation or literature for catalogue '
                       f'effect(s) {", ".join(missing)}; add them to RELATIONS and LITERATURE')
    rows = ['| effect | parameter (unit) | relation | generator draws | fit bounds '
            '| screening starts | family (rivals) | literature |',
            '|---|---|---|---|---|---|---|---|']
    for name, dotted_names in CATALOGUE.items():
        for i, dotted in enumerate(dotted_names):
            spec = SPECS[dotted]
            bounds, starts = _fit_space(name, dotted)
            first = i == 0
            label = f'`{name}`' if first else ''
            if first and name in cand.ABSORBED:
                label += (f' (not searched beside `{cand.ABSORBED[name]}` refitted over '
                          'all its factors: the same parameter)')
            rows.append('| ' + ' | '.join(cell(c) for c in [
                label, f'`{dotted}` ({spec.unit})',
                RELATIONS[name] if first else '', _generator_range(name, dotted),
                bounds, starts, _family(name) if first else '',
                LITERATURE[name] if first else '']) + ' |')
    return '\n'.join(rows) + '\n'


def unsearched_table():
    """Return the table of the schema's effect parameters no catalogue entry searches."""
    searched = {d for names in CATALOGUE.values() for d in names}
    rows = ['| parameter (unit) | default | allowed | meaning |', '|---|---|---|---|']
    for spec in SPECS.values():
        if spec.name.startswith('effects.') and spec.name not in searched:
            rows.append(f'| `{spec.name}` ({spec.unit}) | {number(spec.default)} '
                        f'| {span(spec.low, spec.high, spec.unit)} | {cell(spec.description)} |')
    return '\n'.join(rows) + '\n'


def recalibration_table():
    """Return the table of the nominal parameters refitted beside every candidate."""
    rows = ['| parameter (unit) | refitted within at most (x calibrated value) | meaning |',
            '|---|---|---|']
    for dotted, (low, high) in cand.RECALIBRATION.items():
        spec = SPECS[dotted]
        rows.append(f'| `{dotted}` ({spec.unit}) | x{number(low)} to x{number(high)} (log) '
                    f'| {cell(spec.description)} |')
    return '\n'.join(rows) + '\n'


#: The shipped example record and the commands the docs show on it.
EXAMPLE_RECORD = 'tca_ros/data/example_recording.csv'
EXAMPLE_COMMAND = ['diagnose', EXAMPLE_RECORD, '--config', 'free_stroke',
                   '--report', 'out/example']
UNCALIBRATED_COMMAND = ['diagnose', EXAMPLE_RECORD, '--config', 'free_stroke', '--no-calibrate']
RUN_TIME = re.compile(r'^(\d+ simulations), [0-9.]+ s$', re.M)


def run_tca_sim(argv):
    """Return what ``tca_sim ARGV`` prints on stdout, run in a scratch directory.

    The scratch directory links ``tca_ros`` to this tree's, so relative paths in the
    command and in its output read as they would from the repository root.
    """
    out = io.StringIO()
    with tempfile.TemporaryDirectory() as scratch:
        os.symlink(ROOT / 'tca_ros', pathlib.Path(scratch) / 'tca_ros')
        cwd = os.getcwd()
        os.chdir(scratch)
        try:
            with contextlib.redirect_stderr(io.StringIO()):
                status = tca_sim(argv + ['--quiet'], out=out)
        finally:
            os.chdir(cwd)
    if status != 0:
        raise RuntimeError(f'tca_sim {" ".join(argv)} exited {status}')
    return out.getvalue()


def example_block():
    """Return the fenced block of the example: the command and all it prints."""
    text = run_tca_sim(EXAMPLE_COMMAND)
    return '```text\n$ tca_sim ' + ' '.join(EXAMPLE_COMMAND) + '\n' + text + '```\n'


def uncalibrated_block():
    """Return the fenced block of the example without calibration: its search and result."""
    lines = run_tca_sim(UNCALIBRATED_COMMAND).splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith('candidates'))
    last = next(i for i, line in enumerate(lines) if line.startswith('verdict:'))
    kept = [line for line in lines[first + 1:last + 1]
            if not re.match(r'\s+\d+\. ', line) and not line.startswith('  not testable')]
    return ('```text\n$ tca_sim ' + ' '.join(UNCALIBRATED_COMMAND) + '\n...\n'
            + '\n'.join(kept) + '\n```\n')


def same_but_run_time(old, new):
    """Return True when two example blocks differ at most in their run time (s)."""
    return RUN_TIME.sub(r'\1', old) == RUN_TIME.sub(r'\1', new)


EXAMPLES = {'example': example_block, 'example-uncalibrated': uncalibrated_block}
TABLES = {'catalogue': catalogue_table, 'unsearched-effect-parameters': unsearched_table,
          'recalibration': recalibration_table}


def render(text, path='doc', examples=False):
    """Return ``text`` with every generated block replaced by what the code gives.

    Example blocks are run only with ``examples`` (else left as they are) and kept
    as they are when only their run time differs. Raises KeyError naming ``path``
    and the block for a block name neither TABLES nor EXAMPLES has.
    """
    def replace(match):
        name, body = match.group('name'), match.group('body')
        if name in EXAMPLES:
            new = EXAMPLES[name]() if examples else body
            if same_but_run_time(body, new):
                new = body
        elif name in TABLES:
            new = TABLES[name]()
        else:
            raise KeyError(f'{path}: unknown generated block {name!r} '
                           f'(known: {", ".join(list(TABLES) + list(EXAMPLES))})')
        return match.group(1) + new + match.group(4)
    return BLOCK.sub(replace, text)


def blocks(text):
    """Return the names of the generated blocks in ``text``, in order."""
    return [m.group('name') for m in BLOCK.finditer(text)]


def main(argv=None):
    """Rewrite (or with --check, compare) the generated blocks of DOCS; return exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--check', action='store_true',
                        help='change nothing; exit 1 when a block differs from the code')
    parser.add_argument('--examples', action='store_true',
                        help='run the example commands too (about a minute)')
    args = parser.parse_args(argv)
    stale = []
    for rel in DOCS:
        path = ROOT / rel
        text = path.read_text(encoding='utf-8')
        new = render(text, rel, examples=args.examples)
        if new != text:
            stale.append(rel)
            if not args.check:
                path.write_text(new, encoding='utf-8')
    verb = 'differ from the code' if args.check else 'rewritten'
    for rel in stale:
        print(f'{rel}: generated tables {verb}')
    return 1 if args.check and stale else 0


if __name__ == '__main__':
    sys.exit(main())
