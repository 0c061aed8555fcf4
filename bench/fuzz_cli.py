"""Seeded, budgeted fuzz campaign of `tca_sim` with malformed inputs (issue 10).

Builds malformed profile CSVs, diagnosis records, statics flags and byte-flipped
or truncated MCAP bags (including each input of issue 10, items 7-11), runs
``tca_sim`` on each in a forked child with a wall-time and memory cap, and prints
a table per family: exit codes, tracebacks, internal errors, hangs, stderr that is
not one short line, NaN printed with exit 0, peak memory and wall time. For an
MCAP flip that exits 0 it tells whether the record read is identical to the
intact bag's (the flip hit bytes the reader ignores) or altered. Printed
figures, not assertions.

    python bench/fuzz_cli.py                          # 1000 cases, seed 10
    python bench/fuzz_cli.py --cases 200 --seed 3 --budget 120 --jobs 1
"""
import argparse
import collections
import json
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback

os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')  # forked children: one core each
os.environ.setdefault('MPLBACKEND', 'Agg')

import numpy as np  # noqa: E402

# what the children import on their way: loaded once here, shared by every fork
import tca_ros.calibration.calibration  # noqa: E402, F401, I100, I202
from tca_ros.cli.main import main, MESSAGE_CHARS  # noqa: E402
from tca_ros.diagnosis import diagnose  # noqa: E402, F401 (loaded before forking)
import tca_ros.diagnosis.fitting  # noqa: E402, F401
import tca_ros.model.rig_simulation  # noqa: E402, F401
from tca_ros.params.config_search import config_dir  # noqa: E402
from tca_ros.records.data import read_record  # noqa: E402

# A hang is a run past its stated limit, measured in CPU seconds of the child (the
# machine is shared: wall time there says more about the neighbours than about tca_sim).
# simulate and statics: the limits in cli/main.py keep a run under 30 s of CPU; diagnose: its
# steps limit allows about 500 s (cli/main.py); the records here are 4 s at most (a few
# thousand steps), so 300 s of CPU is far past anything they may take.
CPU_LIMIT_S = {'simulate': 30.0, 'statics': 30.0, 'diagnose': 300.0}
WALL_CAP_S = 1800.0  # s of wall time after which a child is killed whatever its CPU time
TICK_S = 1.0 / os.sysconf('SC_CLK_TCK')
MEMORY_CAP = 3 << 30  # bytes of address space per child: a runaway fails, not the host
STDERR_LIMIT = MESSAGE_CHARS + 200  # chars: an error line longer than this echoes input
FAMILIES = ('simulate', 'diagnose_csv', 'statics', 'mcap')
WEIGHTS = (0.4, 0.25, 0.15, 0.2)  # share of the cases per family
# A diagnosis with the config's rod model costs 10-90 s of CPU even for a 3 s record (rod
# tables), with cst 3-20 s: the input handling is the same, so most cases use cst.
CST_SHARE = 0.8
NO_CALIBRATE_SHARE = 0.7  # the calibration is 60 % of a small diagnosis; most skip it

EVIL_NUMBERS = [
    '1e308', '-1e308', '1e999', '-1e999', 'nan', 'NaN', 'inf', '-inf', 'Infinity', '',
    ' ', '1_000', '\uff11', '\u0661\u0662', '0x10', 'abc', '1e-320', '-0', '-0.5', '+.5',
    '5.', '1,5', '"1"', '1e', 'e5', '--1', '1..2', '\u00a01', '1e5', '1e9', '0', '-1',
    '4.9e-324', '1' * 400, 'x' * 200_000, '9' * 5000, '\x00', '\u202e1',
]
EVIL_RATES = ['0', '-1', '1e-9', '1e-3', '1e308', '1e9', '1e6', 'nan', 'inf', '1_0', '',
              '\uff15', '100', '10', '1e3', 'x' * 3000]
EVIL_PATHS = ['../../../../etc/passwd', '/etc/passwd', '/dev/zero', '/', '..', 'nope',
              'free_stroke', 'conical', 'self_coiled', 'sub/free_stroke', '\x00x',
              'x' * 5000, 'free_stroke.yaml', '/proc/self/environ']


# -- case builders ---------------------------------------------------------------------
def _valid_profile(rng):
    n = rng.randint(2, 12)
    dt = rng.choice([0.1, 0.5, 1.0])
    with_load = rng.random() < 0.5
    rows = ['time,power,load' if with_load else 'time,power']
    for i in range(n):
        cells = [f'{i * dt:g}', f'{rng.choice([0.0, 0.5, 1.0]):g}']
        if with_load:
            cells.append(f'{rng.choice([0.1, 0.2943, 0.5]):g}')
        rows.append(','.join(cells))
    return rows


def _mutate_rows(rng, rows, numeric_from=1):
    """Return text of ``rows`` with one or two random malformations."""
    rows = list(rows)
    for _ in range(rng.choice([1, 1, 2])):
        if not rows:
            break
        kind = rng.randrange(14)
        i = rng.randrange(numeric_from, len(rows)) if len(rows) > numeric_from else 0
        cells = rows[i].split(',')
        if kind <= 4:  # a bad value in a cell
            cells[rng.randrange(len(cells))] = rng.choice(EVIL_NUMBERS)
            rows[i] = ','.join(cells)
        elif kind == 5:  # a field too many or too few
            rows[i] = ','.join(cells + ['1'] if rng.random() < 0.5 else cells[:-1])
        elif kind == 6:  # header column renamed, repeated or dropped
            head = rows[numeric_from - 1].split(',')
            j = rng.randrange(len(head))
            head[j] = rng.choice(['power', 'time', 'load', 'volts', '\ufefftime', ' ', 'Time'])
            rows[numeric_from - 1] = ','.join(head)
        elif kind == 7:  # times out of order or huge
            cells[0] = rng.choice(['1e5', '1e6', '1e308', '-1e308', '0', '1e15', '3e9'])
            rows[i] = ','.join(cells)
        elif kind == 8:  # rows removed
            del rows[numeric_from:numeric_from + rng.randint(1, 5)]
        elif kind == 9:  # a comment or blank line somewhere
            rows.insert(i, rng.choice(['#', '', '  ', '# tca: x', ',,,', '"', '"a\nb"']))
        elif kind == 10:  # CRLF or tabs
            rows = [r + '\r' for r in rows] if rng.random() < 0.5 else \
                [r.replace(',', '\t') for r in rows]
        elif kind == 11:  # a row duplicated
            rows.insert(i, rows[i])
        elif kind == 12:  # everything gone
            rows = rows[:rng.randint(0, 1)]
        else:  # whitespace around values
            rows[i] = ' , '.join(cells)
    return '\n'.join(rows) + '\n'


def _encode(rng, text):
    data = text.encode('utf-8')
    roll = rng.random()
    if roll < 0.06:
        data = b'\xef\xbb\xbf' + data  # BOM
    elif roll < 0.12:
        pos = rng.randrange(len(data) + 1)
        data = data[:pos] + rng.choice([b'\xff', b'\xc3', b'\xe4', b'\x80\x80']) + data[pos:]
    elif roll < 0.15:
        data = text.encode('utf-16')
    return data


def simulate_case(rng, folder):
    text = _mutate_rows(rng, _valid_profile(rng)) if rng.random() < 0.85 else \
        '\n'.join(_valid_profile(rng)) + '\n'
    path = os.path.join(folder, 'profile.csv')
    with open(path, 'wb') as fh:
        fh.write(_encode(rng, text))
    argv = ['simulate', '--input', path, '--model', rng.choice(['cst', 'love', 'cst'])]
    if rng.random() < 0.35:
        argv += [rng.choice(['--rate', '--physics-rate']), rng.choice(EVIL_RATES)]
    if rng.random() < 0.1:
        argv += ['--config', rng.choice(EVIL_PATHS)]
    if rng.random() < 0.05:
        argv += [rng.choice(['--max-steps', '--max-samples']),
                 rng.choice(['0', '-1', '1', 'x', '1e3', '10'])]
    return argv


def _valid_record(rng, rate=None, n=None):
    n = n or rng.randint(20, 40)
    rate = rate or rng.choice([10.0, 20.0, 100.0])
    head = ['# tca: free_stroke', '# mass_kg: 0.03', f'# sample_rate_hz: {rate:g}']
    rows = ['time,power,load,displacement,temperature']
    for i in range(n):
        up = min(i, n - i)
        rows.append(f'{i / rate:.6g},{0.5 if i < n // 2 else 0.0},0.2943,'
                    f'{1e-4 * up:.6g},{25 + 0.1 * up:.3f}')
    return head, rows


def _diagnose_model(rng):
    """Return the --model / --no-calibrate flags of a diagnose case: mostly the fast ones."""
    return (['--model', 'cst'] if rng.random() < CST_SHARE else []) \
        + (['--no-calibrate'] if rng.random() < NO_CALIBRATE_SHARE else [])


def diagnose_case(rng, folder):
    head, rows = _valid_record(rng)
    roll = rng.random()
    if roll < 0.3:  # a header value
        key = rng.randrange(3)
        name = head[key].split(':')[0]
        values = EVIL_PATHS if key == 0 else EVIL_NUMBERS + ['1e-3', '1e-6', '1e-9']
        head[key] = f'{name}: {rng.choice(values)}'
        text = '\n'.join(head + rows) + '\n'
    elif roll < 0.4:  # the issue's timestamp cases
        times = rng.choice([('last', '1e6'), ('first', '-1e308'), ('last', '1e308'),
                            ('last', '3e5')])
        i = len(rows) - 1 if times[0] == 'last' else 1
        cells = rows[i].split(',')
        cells[0] = times[1]
        rows[i] = ','.join(cells)
        text = '\n'.join(head + rows) + '\n'
    elif roll < 0.45:
        text = '\n'.join(head + head[:1] + rows) + '\n'  # a repeated header key
    else:
        text = '\n'.join(head) + '\n' + _mutate_rows(rng, rows)
    path = os.path.join(folder, 'rec.csv')
    with open(path, 'wb') as fh:
        fh.write(_encode(rng, text))
    argv = ['diagnose', path, '--quiet'] + _diagnose_model(rng)
    if rng.random() < 0.1:
        argv += ['--config', rng.choice(EVIL_PATHS)]
    if rng.random() < 0.1:
        argv += ['--report', rng.choice([os.path.join(folder, 'missing', 'deeper'), path])]
    return argv


def statics_case(rng, folder):
    argv = ['statics', '--model', rng.choice(['cst', 'love'])]
    for flag in ('--tmin', '--tmax', '--tstep', '--mass'):
        if rng.random() < 0.35:
            argv += [flag, rng.choice(EVIL_NUMBERS[:34] + ['1e-9', '1e-12', '300', '-300'])]
    if rng.random() < 0.15:
        argv = ['statics', '--config', 'conical', '--tstep', rng.choice(['67.5', '1e-9', '0']),
                '--shape', rng.choice([os.path.join(folder, 'no', 'such', 'dir', 's.csv'),
                                       folder, os.path.join(folder, 's.csv')])]
    if rng.random() < 0.1:
        argv += ['--config', rng.choice(EVIL_PATHS)]
    return argv


class Bags:
    """An intact MCAP bag of the node's topics and the Record read from it."""

    def __init__(self, folder):
        sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', 'test'))
        from test_diagnosis_bag import write_stamped_bag
        self.dir = os.path.join(folder, 'intact')
        write_stamped_bag(self.dir)
        self.file = next(f for f in os.listdir(self.dir) if f.endswith('.mcap'))
        with open(os.path.join(self.dir, self.file), 'rb') as fh:
            self.data = fh.read()
        self.record = read_record(os.path.join(self.dir, self.file))


def mcap_case(rng, folder, bags):
    target = os.path.join(folder, 'bag')
    os.makedirs(target, exist_ok=True)
    data = bytearray(bags.data)
    roll = rng.random()
    if roll < 0.7:  # byte flips
        for _ in range(rng.choice([1, 1, 1, 2, 4])):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        kind = 'flip'
    elif roll < 0.8:
        data = data[:rng.randrange(len(data))]
        kind = 'truncated'
    elif roll < 0.9:  # garbage beside an intact bag, asked for by name
        shutil.copy(os.path.join(bags.dir, bags.file), os.path.join(target, bags.file))
        data = bytearray(rng.randbytes(rng.randint(0, 4000)))
        if rng.random() < 0.5:
            data[:8] = b'\x89MCAP0\r\n'
        kind = 'garbage'
    else:
        kind = 'intact'
    path = os.path.join(target, 'other.mcap' if kind == 'garbage' else bags.file)
    with open(path, 'wb') as fh:
        fh.write(bytes(data))
    # the bag reader is what these cases test: the cheapest diagnosis (one reuse key)
    argv = ['diagnose', path, '--config', 'free_stroke', '--quiet', '--model', 'cst',
            '--no-calibrate']
    return argv, kind, path


def _write(folder, name, data):
    path = os.path.join(folder, name)
    with open(path, 'wb') as fh:
        fh.write(data if isinstance(data, bytes) else data.encode('utf-8'))
    return path


def _record_text(rate=10.0, n=30, tca='free_stroke', first=None, last=None):
    head, rows = _valid_record(random.Random(0), rate, n)
    head[0] = f'# tca: {tca}'
    for i, value in ((1, first), (len(rows) - 1, last)):
        if value is not None:
            rows[i] = ','.join([value] + rows[i].split(',')[1:])
    return '\n'.join(head + rows) + '\n'


def _cold_config(folder):
    with open(os.path.join(config_dir(), 'free_stroke.yaml'), encoding='utf-8') as fh:
        lines = [line if 'convection_coefficient' not in line else
                 line.split(':')[0] + ': 0.0' for line in fh.read().splitlines()]
    return _write(folder, 'cold.yaml', '\n'.join(lines) + '\n')


def issue_cases():
    """Return builders (folder, bags) -> argv of the exact inputs of issue 10, items 7-11."""
    sim = ['simulate', '--model', 'cst', '--input']
    ok = 'time,power\n0,1\n10,0\n'

    def diag(**kw):
        return lambda f, b: ['diagnose', _write(f, 'rec.csv', _record_text(**kw)), '--quiet']

    def prof(text, *flags):
        return lambda f, b: sim + [_write(f, 'p.csv', text), *flags]

    def garbage_beside(f, b):
        target = os.path.join(f, 'bag')
        shutil.copytree(b.dir, target)
        return ['diagnose', _write(target, 'other.mcap', b'garbage' * 50), '--config',
                'free_stroke', '--quiet']

    return [
        # item 7
        diag(n=20, rate=10.0), diag(n=20, rate=20.0), diag(n=25, rate=100.0),
        diag(n=30, rate=1000.0), diag(first='-1e308'),
        prof('time,power\n0,1\n1e308,1\n'), prof('time,power\n0,1\n1,' + '1' * 131_073 + '\n'),
        prof(ok, '--physics-rate', '0'), prof(ok, '--physics-rate', '1e308'),
        prof(ok, '--rate', '1e9'),
        lambda f, b: ['statics', '--config', 'conical', '--shape',
                      os.path.join(f, 'missing', 'shape.csv')],
        # item 8
        diag(last='1e6'), diag(rate=1e-3), diag(rate=1e-6),
        prof('time,power\n0,1\n100000,0\n'), prof(ok, '--physics-rate', '1e9'),
        lambda f, b: ['statics', '--model', 'cst', '--tstep', '1e-9'],
        # item 9
        prof(b'time,power\n0,1\n1,\xff\n'), prof('time,power\n0,1e308\n1,0\n'),
        prof('time,power\n0,-1e308\n1,0\n'), prof('time,power\n0,-0.5\n1,0\n'),
        prof('time,power,load\n0,1,1e308\n1,0,0\n'),
        lambda f, b: sim + [_write(f, 'p.csv', ok), '--config', _cold_config(f)],
        prof('time,power,power\n0,1,1\n1,0,0\n'), prof('time,power\n0,1_000\n1,0\n'),
        prof('time,power\n0,\uff11\n1,0\n'), prof('time,power\n0,\u0661\n1,0\n'),
        prof(b'\xef\xbb\xbf' + ok.encode()),
        lambda f, b: ['diagnose', _write(f, 'rec.csv', b'\xef\xbb\xbf'
                                         + _record_text().encode()), '--quiet'],
        prof('time,power\n0,' + 'y' * 1_000_000 + '\n1,0\n'),
        # item 10
        garbage_beside,
        # item 11
        diag(tca='../../../../etc/passwd'),
    ]


# -- running ---------------------------------------------------------------------------
def _child(argv, folder):
    """Run main(argv) in this forked child with its output in folder; never returns."""
    out = os.open(os.path.join(folder, 'stdout'), os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    err = os.open(os.path.join(folder, 'stderr'), os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(out, 1)
    os.dup2(err, 2)
    code = 0
    try:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
        os.chdir(folder)
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 2
    except BaseException:
        traceback.print_exc()
        code = 99
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def cpu_seconds(pid):
    """Return the CPU time (s, user + system) a running child has used so far."""
    try:
        with open(f'/proc/{pid}/stat', encoding='ascii') as fh:
            fields = fh.read().rsplit(')', 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) * TICK_S  # utime, stime (fields 14, 15)


def start(argv, folder):
    pid = os.fork()
    if pid == 0:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        _child(argv, folder)
    return pid


def outcome(folder, status, wall, rss_kb, hung):
    with open(os.path.join(folder, 'stdout'), 'rb') as fh:
        out = fh.read()
    with open(os.path.join(folder, 'stderr'), 'rb') as fh:
        err = fh.read().decode('utf-8', 'replace')
    if hung:
        code = 'hang'
    else:
        code = os.waitstatus_to_exitcode(status)
    return {
        'code': code, 'wall': wall, 'rss_mb': rss_kb / 1024.0,
        'traceback': 'Traceback' in err or code == 99,
        'internal': 'internal error' in err,
        'not_one_line': code not in (0, 'hang') and err.count('\n') != 1,
        'long_err': len(err) > STDERR_LIMIT,
        'nan_ok': code == 0 and (b'nan' in out.lower() or b'inf' in out.lower()),
        'err': err.strip()[:300],
    }


def build_case(family, k, seed, folder, bags, fixed):
    """Return (argv, extra) of case k of ``family``."""
    case_rng = random.Random(f'{seed}-{k}')
    if family == 'issue':
        return fixed[k](folder, bags), {}
    if family == 'mcap':
        argv, kind, path = mcap_case(case_rng, folder, bags)
        extra = {'kind': kind, 'path': path}
        if kind != 'intact':
            extra['identical'] = _same_record(path, bags.record)
        return argv, extra
    return {'simulate': simulate_case, 'diagnose_csv': diagnose_case,
            'statics': statics_case}[family](case_rng, folder), {}


def subprocess_check(argv, folder, res):
    """Rerun argv as a real `tca_sim` process; return its (exit status, error line)."""
    proc = subprocess.run([sys.executable, '-m', 'tca_ros.cli.main', *argv], cwd=folder,
                          stdin=subprocess.DEVNULL, capture_output=True, timeout=WALL_CAP_S)
    return proc.returncode, proc.stderr.decode('utf-8', 'replace').strip()[:300]


def campaign(n_cases, seed, budget, jobs, verbose, only=None, sample=0.0, log=None,
             first=0):
    rng = random.Random(seed)
    root = tempfile.mkdtemp(prefix='fuzz_cli_')
    bags = Bags(root)
    fixed = issue_cases()
    families = ['issue'] * len(fixed) + rng.choices(FAMILIES, WEIGHTS,
                                                    k=max(0, n_cases - len(fixed)))
    # the issue's exact inputs first, then the random ones
    pending = list(enumerate(families))
    if only is not None:  # rebuild one case, keep its files, print them
        pending = [pending[only]]
    pending = pending[first:]  # a campaign resumed where a budget stopped it
    running, results, reusable = {}, [], {}
    t_start = time.monotonic()

    def finish(k, family, folder, argv, extra, res):
        res.update(family=family, argv=argv, **extra)
        results.append(res)
        if family == 'mcap' and extra.get('identical') and not res.get('reused'):
            reusable[tuple(argv[2:])] = res  # the diagnosis of the intact record
        if rng_sample.random() < sample and res['cpu'] < 5.0 and not res.get('reused'):
            code, err = subprocess_check(argv, folder, res)
            res['subprocess_agrees'] = code == res['code'] and err == res['err']
            if not res['subprocess_agrees']:
                res['subprocess'] = [code, err]
        if log is not None:  # one JSON line per case, as it ends
            log.write(json.dumps(dict(res, case=k, argv=[a[:200] for a in argv])) + '\n')
            log.flush()
        if verbose and (res['traceback'] or res['internal'] or res['code'] == 'hang'
                        or res['nan_ok'] or res['not_one_line'] or res['long_err']
                        or res['code'] == 1 or res.get('subprocess_agrees') is False):
            print(f'case {k} {family}: {res["code"]} {argv!r:.300}\n    {res["err"]}'
                  + (f'\n    subprocess: {res["subprocess"]}' if 'subprocess' in res else ''),
                  flush=True)
        if only is None:
            shutil.rmtree(folder, ignore_errors=True)
        else:
            print(f'case {k} kept in {folder}: {argv!r:.500}\n  -> {res["code"]}, '
                  f'{res["wall"]:.1f} s: {res["err"]}')

    rng_sample = random.Random(f'{seed}-subprocess')
    while pending or running:
        while pending and len(running) < jobs and time.monotonic() - t_start < budget:
            k, family = pending.pop(0)
            folder = os.path.join(root, f'case{k:05d}')
            os.makedirs(folder)
            argv, extra = build_case(family, k, seed, folder, bags, fixed)
            known = reusable.get(tuple(argv[2:])) if extra.get('identical') else None
            if known is not None:  # same record as the intact bag: same diagnosis
                finish(k, family, folder, argv, extra, dict(known, reused=True, wall=0.0))
                continue
            running[start(argv, folder)] = (k, family, folder, time.monotonic(), argv, extra)
        if not running:
            break
        time.sleep(0.01)
        for pid, (k, family, folder, t0, argv, extra) in list(running.items()):
            got, status, usage = os.wait4(pid, os.WNOHANG)
            wall = time.monotonic() - t0
            hung = False
            if got == 0:
                if cpu_seconds(pid) < CPU_LIMIT_S[argv[0]] and wall < WALL_CAP_S:
                    continue
                os.kill(pid, signal.SIGKILL)
                got, status, usage = os.wait4(pid, 0)
                hung = True
            del running[pid]
            res = outcome(folder, status, wall, usage.ru_maxrss, hung)
            res['cpu'] = usage.ru_utime + usage.ru_stime
            finish(k, family, folder, argv, extra, res)
    if only is None:
        shutil.rmtree(root, ignore_errors=True)
    return results, time.monotonic() - t_start, len(pending)  # pending: not started (budget)


def _same_record(path, intact):
    try:
        rec = read_record(path)
    except Exception:  # the parent re-reads; any failure means not the intact record
        return False
    return all(np.array_equal(getattr(rec, f), getattr(intact, f))
               for f in ('time', 'power', 'load', 'displacement', 'temperature'))


def table(results, wall, skipped):
    # exit 3: a simulate run ended on a physical event (thread broke or melted), rows kept
    cols = ['cases', 'exit 0', 'exit 1', 'exit 2', 'exit 3', 'other', 'traceback', 'internal',
            'hang', 'not 1 line', 'long err', 'NaN ok', 'max MB', 'max s', 'max cpu s']
    print(f'{"family":<13}' + ''.join(f'{c:>11}' for c in cols))
    groups = collections.defaultdict(list)
    for r in results:
        groups[r['family']].append(r)
    for family in ['issue'] + list(FAMILIES) + ['all']:
        rows = results if family == 'all' else groups.get(family, [])
        if not rows:
            continue
        codes = collections.Counter(r['code'] for r in rows)
        vals = [len(rows), codes[0], codes[1], codes[2], codes[3],
                len(rows) - codes[0] - codes[1] - codes[2] - codes[3] - codes['hang'],
                sum(r['traceback'] for r in rows), sum(r['internal'] for r in rows),
                codes['hang'], sum(r['not_one_line'] for r in rows),
                sum(r['long_err'] for r in rows), sum(r['nan_ok'] for r in rows),
                f'{max(r["rss_mb"] for r in rows):.0f}', f'{max(r["wall"] for r in rows):.1f}',
                f'{max(r["cpu"] for r in rows):.1f}']
        print(f'{family:<13}' + ''.join(f'{v:>11}' for v in vals))
    mcap = [r for r in results if r['family'] == 'mcap']
    if mcap:
        print('\nMCAP cases by kind: exit codes; for exit 0, record identical to the intact '
              "bag's (flip in bytes the reader ignores) or altered")
        for kind in ('flip', 'truncated', 'garbage', 'intact'):
            rows = [r for r in mcap if r['kind'] == kind]
            if rows:
                codes = collections.Counter(r['code'] for r in rows)
                same = sum(1 for r in rows if r['code'] == 0 and r.get('identical'))
                altered = sum(1 for r in rows if r['code'] == 0 and r.get('identical') is False)
                reused = sum(1 for r in rows if r.get('reused'))
                print(f'  {kind:<10} {len(rows):>4} cases: {dict(sorted(codes.items(), key=str))}'
                      f'; exit 0 identical {same}, altered {altered}; outcome of the intact '
                      f'record reused {reused}')
    checked = [r['subprocess_agrees'] for r in results if 'subprocess_agrees' in r]
    print(f'\nsubprocess sample: {len(checked)} cases rerun as `python -m tca_ros.cli.main`, '
          f'{sum(checked)} with the same exit status and error line')
    print(f'{len(results)} cases in {wall:.0f} s wall, '
          f'{sum(r["cpu"] for r in results):.0f} s CPU in the children'
          + (f'; {skipped} not run (budget)' if skipped else ''))


def main_fuzz(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cases', type=int, default=1000, help='malformed inputs')
    parser.add_argument('--seed', type=int, default=10, help='campaign seed')
    parser.add_argument('--budget', type=float, default=1500.0,
                        help='wall-time budget (s); cases not started by then are skipped')
    parser.add_argument('--jobs', type=int, default=2, help='children at a time')
    parser.add_argument('--verbose', action='store_true',
                        help='print each failure and each exit status 1')
    parser.add_argument('--sample', type=float, default=0.03,
                        help='share of the quick cases rerun as a real process to check the '
                             'forked in-process run against it')
    parser.add_argument('--log', default=None,
                        help='append one JSON line per case to this file as it ends')
    parser.add_argument('--first', type=int, default=0,
                        help='start at this case number (resume a campaign its budget stopped)')
    parser.add_argument('--case', type=int, default=None,
                        help='rebuild and run only this case number; keep its files')
    args = parser.parse_args(argv)
    log = open(args.log, 'a', encoding='utf-8') if args.log else None
    results, wall, skipped = campaign(args.cases, args.seed, args.budget, args.jobs,
                                      args.verbose, only=args.case, sample=args.sample,
                                      log=log, first=args.first)
    table(results, wall, skipped)


if __name__ == '__main__':
    main_fuzz()
