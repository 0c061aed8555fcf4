"""One muscle, one diagnosis: each real muscle's records diagnosed together (issue 25).

    python bench/bench_real_muscles.py [--model cst] [--muscles NAME ...]

For each real muscle of ../shared/realdata (skipped when absent), described as
bench_transfer.py describes it from its README, all its records are diagnosed
together twice: against the description (its stated uncertainties are the priors)
and against the file `tca_sim calibrate` writes from the same records (default fit;
its posterior's spreads are the description's uncertainties then). Printed per muscle and start:
the verdict, what is named or helps, the held-out RMSE beside the repeats' spread on
the same samples, the CPU time, the findings (values moved beyond their stated spread,
in spreads), the verdict's sentence and, for an unexplained verdict whose residual one
moment carries, where (calibration/where.py). Figures, not assertions.
"""
import one_blas_thread  # noqa: F401  (before NumPy: one BLAS thread per process)
import argparse  # noqa: I100, I201
import glob
import io
import os
import re
import sys
import tempfile
import time

from bench_transfer import MUSCLES, REAL

from tca_ros.cli.main import main as tca_sim
from tca_ros.diagnosis import diagnose
from tca_ros.model.muscle import describe_muscle
from tca_ros.params.files import dump_params
from tca_ros.params.thread_presets import load_thread_presets

REPEATS = re.compile(r'records with repeats \(([\d.]+) mm\) is (below|above) the spread '
                     r'between repeated runs on the same samples \(([\d.]+) mm')


def _row(paths, config, model):
    """Return (verdict, named, helpful, findings, repeats, CPU s, sentence, where notes)."""
    start = time.process_time()
    result = diagnose(paths, config, model=model, progress=False)
    cpu = time.process_time() - start
    findings = ', '.join(f'{n} {z:+.1f}' for n, z, _ in result.calibration.findings()) \
        if result.calibration is not None else ''
    repeat = next((m for m in map(REPEATS.search, result.notes) if m), None)
    repeat = (f'{repeat.group(1)} {"<" if repeat.group(2) == "below" else ">"} '
              f'{repeat.group(3)} mm' if repeat else '-')
    where = [n.split(': one moment')[0] for n in result.notes if ' is concentrated: ' in n]
    return (result.verdict, '+'.join(result.effects) or '-',
            '+'.join(result.helpful) or '-', findings or '-', repeat, cpu,
            result.explanation, where)


def _with_header(path, directory, key, value):
    """Return the path of a temporary copy of the CSV ``path`` with ``# key: value`` added."""
    os.makedirs(directory, exist_ok=True)
    with open(path, encoding='utf-8') as fh:
        lines = fh.readlines()
    at = next(i for i, line in enumerate(lines) if not line.startswith('#'))
    copy = os.path.join(directory, os.path.basename(path))
    with open(copy, 'w', encoding='utf-8') as fh:
        fh.writelines(lines[:at] + [f'# {key}: {value}\n'] + lines[at:])
    return copy


def main(argv=None):
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--model', default='cst', choices=('rod', 'cst', 'love'))
    parser.add_argument('--muscles', nargs='+', default=list(MUSCLES), choices=MUSCLES)
    parser.add_argument('--width', type=int, default=400, help='verdict sentence characters')
    parser.add_argument('--power-logged', default='command', choices=('command', 'measured'),
                        help="what the records' power column is (the READMEs: the nominal "
                             'power times the logged on/off signal, so the command); the '
                             'records are read from a temporary copy with that header')
    args = parser.parse_args(argv)
    print(f'model {args.model}; all records of each muscle diagnosed together; power '
          f'logged as {args.power_logged}')
    print(f'{"muscle":<14s} {"start":<12s} {"verdict":<12s} {"named":<20s} {"helpful":<20s} '
          f'{"held-out vs repeats":<20s} {"CPU s":>6s}  findings (z)')
    with tempfile.TemporaryDirectory() as work:
        for name in args.muscles:
            paths = sorted(glob.glob(os.path.join(REAL, name, 'records', '*.csv')))
            if not paths:
                print(f'{name:<14s} no records under {REAL}; skipped')
                continue
            paths = [_with_header(p, os.path.join(work, name), 'power_logged',
                                  args.power_logged) for p in paths]
            params = describe_muscle(MUSCLES[name], load_thread_presets()).params
            described = os.path.join(work, f'{name}.yaml')
            dump_params(params, described)
            calibrated = os.path.join(work, f'{name}_cal.yaml')
            status = tca_sim(['calibrate', *paths, '--config', described, '--model', args.model,
                              '--out', calibrated, '--quiet'], out=io.StringIO())
            if status != 0:
                print(f'{name:<14s} calibrate failed (exit status {status}); skipped')
                continue
            for label, config in (('description', described), ('calibrated', calibrated)):
                verdict, named, helpful, findings, repeat, cpu, why, where = _row(
                    paths, config, args.model)
                print(f'{name:<14s} {label:<12s} {verdict:<12s} {named:<20s} {helpful:<20s} '
                      f'{repeat:<20s} {cpu:6.1f}  {findings}\n    {why[:args.width]}'
                      + ''.join(f'\n    where: {n}' for n in where), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
