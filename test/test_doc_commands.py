"""Every command block of README.md and docs/*.md runs, as written, from a fresh clone.

The convention, for whoever writes the docs:

- A fence opened with ```bash or ```sh is a command block and is run. Other fences
  (```text, ```python, ```yaml, ```console, ...) are never run.
- A command block that needs the ``ros2`` command line or colcon (neither is on PyPI) is
  marked by an HTML comment on the line right before its fence, and skipped:
  ``<!-- doc-test: needs ros2 -->`` or ``<!-- doc-test: needs colcon -->``. A marked block
  must contain a ``ros2`` or ``colcon`` command, or give the reason in parentheses
  (``<!-- doc-test: needs ros2 (my_run is a ros2 bag) -->``). Nothing else is skipped; a
  ```console block must contain a ``ros2`` or ``colcon`` command too.
- A ```text block right after ``<!-- doc-test: output -->`` is output of the command block
  before it: each of its non-empty lines must be a line of that block's stdout.

How the blocks run:

- Each page runs in its own fresh copy of the clone (the files git tracks, plus new files
  git does not ignore), from the top directory, all its blocks in order in one bash shell
  with ``set -e -o pipefail``: a block may use what an earlier block of the page made.
- ``.venv`` is already installed: its entries link to the environment running this test
  (installing needs the network and minutes), with a fresh ``.venv/.installed`` stamp, so
  ``make install`` and ``make demo`` find it up to date (checked with ``make -q install``
  before anything runs). README.md and docs/quickstart.md start from a shell without the
  venv (they activate it themselves); every other page starts with ``.venv`` activated, as
  docs/quickstart.md says the pages assume.
- ``make test`` runs as ``make -n test`` (a dry run): it is the suite this test belongs to.
- Checked: every block exits with status 0 and writes no Python traceback; every file a
  command names with ``--out``, ``--report``, ``--plot``, ``--shape`` or ``> FILE`` exists
  afterwards (a file non-empty, a directory not empty); the expected outputs above.
"""
from concurrent.futures import ThreadPoolExecutor
import os
import pathlib
import re
import shlex
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGES = [ROOT / 'README.md'] + sorted((ROOT / 'docs').glob('*.md'))
BARE_PAGES = ('README.md', 'docs/quickstart.md')  # pages that set up and activate the venv
FENCE = re.compile(r'^(\s*)```\s*([\w+-]*)\s*$')
MARK = re.compile(r'^\s*<!--\s*doc-test:\s*(.*?)\s*-->\s*$')
NEEDS = re.compile(r'needs (ros2|colcon)(\s*\((.+)\))?$')
NEEDS_CLI = re.compile(r'(^|[\s;&|(])(ros2|colcon)\s')
RUN_LANGUAGES = ('bash', 'sh')
OUTPUT_OPTIONS = ('--out', '--report', '--plot', '--shape')
PAGE_TIMEOUT_S = 300.0
PARALLEL_PAGES = 2  # pages run at once (the slowest, README.md's make demo, is mostly waiting)
#: pages whose blocks take 15 s or more (a diagnosis, a calibration and its posterior band,
#: make demo): the slow tier of the suite runs them (``make test-slow``; docs/cli.md)
SLOW_PAGES = ('README.md', 'docs/controllers.md', 'docs/diagnosis.md', 'docs/own_muscle.md',
              'docs/quickstart.md')
BLOCK_MARK = '@@doc-test block {}@@'


def page_blocks(path):
    """Return [(line, language, text, mark)] of every fenced block of a markdown page."""
    blocks, lines, i = [], path.read_text(encoding='utf-8').splitlines(), 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if not match or not match.group(2):
            i += 1
            continue
        indent, language, start = len(match.group(1)), match.group(2), i + 1
        previous = next((ln for ln in reversed(lines[:i]) if ln.strip()), '')
        mark = MARK.match(previous)
        body = []
        i += 1
        while i < len(lines) and not FENCE.match(lines[i]):
            body.append(lines[i][indent:] if lines[i][:indent].strip() == '' else lines[i])
            i += 1
        blocks.append((start, language, '\n'.join(body), mark.group(1) if mark else None))
        i += 1
    return blocks


def planned(path):
    """Return (blocks to run [(line, text, expected lines)], skipped lines, problems)."""
    runs, skipped, problems = [], [], []
    for line, language, text, mark in page_blocks(path):
        if mark == 'output':
            if language != 'text' or not runs:
                problems.append(f'line {line}: an output mark needs a ```text block after a '
                                'command block')
            else:
                runs[-1][2].extend(ln for ln in text.splitlines() if ln.strip())
            continue
        needs = NEEDS.match(mark) if mark else None
        if mark and not needs:
            problems.append(f'line {line}: unknown mark {mark!r} (needs ros2, needs colcon, '
                            'output)')
        if language == 'console' or needs:
            if not NEEDS_CLI.search(' ' + text) and not (needs and needs.group(3)):
                problems.append(f'line {line}: a block marked or fenced as needing ros2 or '
                                'colcon has no ros2 or colcon command and gives no reason')
            if language in RUN_LANGUAGES:
                skipped.append(line)
            continue
        if language in RUN_LANGUAGES:
            runs.append((line, text, []))
    return runs, skipped, problems


def named_outputs(text):
    """Return the paths the commands of a block write (--out X, --plot X, > X, ...)."""
    paths = []
    for command in text.replace('\\\n', ' ').splitlines():
        try:
            words = shlex.split(command, comments=True)
        except ValueError:
            continue
        for i, word in enumerate(words[:-1]):
            if word in OUTPUT_OPTIONS or word == '>':
                paths.append(words[i + 1])
    return paths


def fresh_clone(dest):
    """Copy the clone's files (tracked, and untracked but not ignored) to ``dest``."""
    listed = subprocess.run(['git', 'ls-files', '-co', '--exclude-standard', '-z'], cwd=ROOT,
                            capture_output=True, check=True).stdout.decode().split('\0')
    for name in filter(None, listed):
        source = ROOT / name
        if source.is_file():
            target = dest / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    venv = dest / '.venv'
    venv.mkdir()
    for entry in pathlib.Path(sys.prefix).iterdir():
        if entry.name != '.installed':
            (venv / entry.name).symlink_to(entry)
    (venv / '.installed').touch()
    stamp = (venv / '.installed').stat().st_mtime + 1.0
    os.utime(venv / '.installed', (stamp, stamp))
    return dest


def bare_environment(copy):
    """Return the environment of a newcomer's shell: no venv, the copy's package first."""
    env = dict(os.environ)
    venv_bin = os.path.dirname(sys.executable)
    env['PATH'] = os.pathsep.join(p for p in env.get('PATH', '').split(os.pathsep)
                                  if p and os.path.realpath(p) != os.path.realpath(venv_bin))
    env.pop('VIRTUAL_ENV', None)
    env['PYTHONPATH'] = str(copy)
    env.update(OPENBLAS_NUM_THREADS='1', OMP_NUM_THREADS='1', MPLBACKEND='Agg')
    return env


def script_of(runs, activate):
    lines = ['set -e -o pipefail']
    if activate:
        lines.append('. .venv/bin/activate')
    for k, (_, text, _) in enumerate(runs):
        text = re.sub(r'(?m)^(\s*)make test\b', r'\1make -n test', text)
        lines += [f"echo '{BLOCK_MARK.format(k)}'; echo '{BLOCK_MARK.format(k)}' >&2", text]
    return '\n'.join(lines) + '\n'


def split_by_block(text, count):
    parts = re.split(r'@@doc-test block (\d+)@@\n', text)
    found = {int(parts[j]): parts[j + 1] for j in range(1, len(parts) - 1, 2)}
    return [found.get(k) for k in range(count)]


def test_the_pages_follow_the_convention():
    problems = []
    for page in PAGES:
        problems += [f'{page.relative_to(ROOT)}: {p}' for p in planned(page)[2]]
    assert not problems, '\n'.join(problems)
    line, language, text, mark = page_blocks(ROOT / 'README.md')[0]
    commands = [c.split('#')[0].strip() for c in text.splitlines() if c.strip()]
    assert (language, mark, commands[:2]) == ('bash', None, ['make demo', 'make test']), \
        'README.md must start with the two commands make demo and make test'


def test_named_outputs_and_the_convention_parser(tmp_path):
    assert named_outputs('tca_sim a --out out/x \\\n  --plot p.png > s.csv  # --out no') == [
        'out/x', 'p.png', 's.csv']
    page = tmp_path / 'page.md'
    page.write_text('<!-- doc-test: needs ros2 -->\n```bash\nros2 run x\n```\n'
                    '<!-- doc-test: needs ros2 -->\n```bash\necho hidden\n```\n'
                    '```bash\necho shown\n```\n<!-- doc-test: output -->\n```text\nshown\n```\n'
                    '```console\n$ tca_sim demo\n```\n')
    runs, skipped, problems = planned(page)
    assert [r[1] for r in runs] == ['echo shown'] and runs[0][2] == ['shown']
    assert skipped == [2, 6]
    assert len(problems) == 2  # a skipped block without ros2, a console block without ros2


def run_page(page, folder):
    """Run a page's command blocks in a fresh copy; return (runs, copy, CompletedProcess)."""
    runs = planned(page)[0]
    name = str(page.relative_to(ROOT))
    copy = fresh_clone(folder)
    env = bare_environment(copy)
    fresh = subprocess.run(['make', '-q', 'install'], cwd=copy, env=env, capture_output=True)
    if fresh.returncode != 0:
        raise RuntimeError('the provided .venv is not up to date for make; not running')
    result = subprocess.run(['bash', '-c', script_of(runs, name not in BARE_PAGES)], cwd=copy,
                            env=env, capture_output=True, text=True, timeout=PAGE_TIMEOUT_S)
    return runs, copy, result


@pytest.fixture(scope='module')
def page_results(request, tmp_path_factory):
    """Start every selected page with command blocks (PARALLEL_PAGES at once); page -> future.

    Only the pages whose test this session runs (``-m slow``, ``-m "not slow"``, ``-k``).
    """
    selected = {item.callspec.params['page'] for item in request.session.items
                if item.originalname == 'test_every_command_block_runs'}
    pool = ThreadPoolExecutor(max_workers=PARALLEL_PAGES)
    futures = {page: pool.submit(run_page, page, tmp_path_factory.mktemp('clone'))
               for page in PAGES if page in selected and planned(page)[0]
               and not planned(page)[2]}
    yield futures
    pool.shutdown(wait=True, cancel_futures=True)


def _page_parameter(page):
    name = str(page.relative_to(ROOT))
    return pytest.param(page, id=name, marks=[pytest.mark.slow] if name in SLOW_PAGES else [])


@pytest.mark.parametrize('page', [_page_parameter(p) for p in PAGES])
def test_every_command_block_runs(page, page_results):
    assert not planned(page)[2]
    if page not in page_results:
        pytest.skip('no command blocks to run on this page')
    name = str(page.relative_to(ROOT))
    runs, copy, result = page_results[page].result()
    outs = split_by_block(result.stdout, len(runs))
    errs = split_by_block(result.stderr, len(runs))
    for k, (line, text, expected) in enumerate(runs):
        where = f'{name} line {line}:\n{text}\n--- stdout:\n{(outs[k] or "")[-3000:]}\n' \
                f'--- stderr:\n{(errs[k] or "")[-3000:]}'
        assert outs[k] is not None, f'never reached: {where}'
        last = k == len(runs) - 1 or outs[k + 1] is None
        if last:
            assert result.returncode == 0, f'exit status {result.returncode}: {where}'
        assert 'Traceback (most recent call last)' not in (errs[k] or ''), where
        got = set((outs[k] or '').splitlines())
        missing = [ln for ln in expected if ln not in got]
        assert not missing, f'expected output lines missing {missing}: {where}'
        for path in named_outputs(text):
            target = copy / path
            assert target.exists(), f'{path} was not written: {where}'
            if target.is_dir():
                assert any(target.iterdir()), f'{path} is empty: {where}'
            else:
                assert target.stat().st_size > 0, f'{path} is empty: {where}'
