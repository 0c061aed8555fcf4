"""Imports point one way: rod <- model <- params <- records <- calibration <- diagnosis.

synthetic above them; toolkit beside them, on the physics and its params files only;
ros and cli on top. The physics (rod, model) reads and writes no files: params does.
"""
import ast
import pathlib
import subprocess
import sys

CHECK = """
import sys
import tca_ros.model.dynamics, tca_ros.model.kinetostatics, tca_ros.model.effects
import tca_ros.model.simulation
try:
    import tca_ros.rod
except ImportError:
    pass
bad = sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'matplotlib')
             or m.startswith(('tca_ros.params', 'tca_ros.records', 'tca_ros.calibration',
                              'tca_ros.diagnosis', 'tca_ros.synthetic', 'tca_ros.ros',
                              'tca_ros.cli')))
print(','.join(bad))
"""


def test_physics_layers_import_neither_rclpy_nor_matplotlib():
    out = subprocess.run([sys.executable, '-c', CHECK], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ''


# --- packages that show the layers (issue 26) ---
PACKAGE_RANK = {'rod': 0, 'model': 1, 'params': 2, 'records': 3, 'calibration': 4,
                'diagnosis': 5, 'synthetic': 6, 'ros': 7, 'cli': 8}
#: toolkit sits beside records..synthetic: it builds on the physics and its params files.
TOOLKIT_MAY_IMPORT = {'rod', 'model', 'params', 'toolkit'}


def _package_of(module):
    parts = module.split('.')
    return parts[1] if len(parts) > 1 else ''


def layer_violations(graph):
    """Return 'a -> b' for each import from a lower layer into a higher one."""
    bad = []
    for module, imported in sorted(graph.items()):
        low = _package_of(module)
        for target in sorted(imported):
            high = _package_of(target)
            if not low or not high or low == high:
                continue
            if low == 'toolkit':
                ok = high in TOOLKIT_MAY_IMPORT
            elif high == 'toolkit':
                ok = PACKAGE_RANK.get(low, 0) >= PACKAGE_RANK['synthetic']
            else:
                ok = PACKAGE_RANK.get(high, 99) < PACKAGE_RANK.get(low, -1)
            if not ok:
                bad.append(f'{module} -> {target}')
    return bad


def test_every_module_lives_in_a_layer_package():
    from test_import_cycles import import_graph
    stray = [m for m in import_graph() if m != 'tca_ros'
             and _package_of(m) not in set(PACKAGE_RANK) | {'toolkit'}]
    assert stray == []


def test_packages_import_one_way():
    from test_import_cycles import import_graph
    assert layer_violations(import_graph()) == []


def test_the_layer_rule_can_fail():
    graph = {'tca_ros.model.a': {'tca_ros.calibration.b'},
             'tca_ros.toolkit.c': {'tca_ros.records.d'},
             'tca_ros.ros.e': {'tca_ros.cli.f'},
             'tca_ros.cli.g': {'tca_ros.ros.h', 'tca_ros.model.i'},
             'tca_ros.model.j': {'tca_ros.params.k'},
             'tca_ros.params.l': {'tca_ros.model.m', 'tca_ros.records.n'}}
    assert layer_violations(graph) == ['tca_ros.model.a -> tca_ros.calibration.b',
                                       'tca_ros.model.j -> tca_ros.params.k',
                                       'tca_ros.params.l -> tca_ros.records.n',
                                       'tca_ros.ros.e -> tca_ros.cli.f',
                                       'tca_ros.toolkit.c -> tca_ros.records.d']


# --- the physics reads and writes no files (issue 26): that is tca_ros.params's job ---
PHYSICS = pathlib.Path(__file__).resolve().parents[1] / 'tca_ros'
#: Modules whose import means files or the environment: file formats, paths, the OS.
FILE_MODULES = {'os', 'io', 'pathlib', 'shutil', 'tempfile', 'glob', 'yaml', 'json', 'csv',
                'pickle', 'shelve', 'sqlite3', 'h5py', 'mcap', 'rosbag2_py'}
#: Calls that read or write files: the builtin open, numpy's and pandas' readers/writers.
FILE_CALLS = {'load', 'save', 'savez', 'savez_compressed', 'loadtxt', 'savetxt', 'genfromtxt',
              'fromfile', 'memmap', 'read_csv', 'read_parquet', 'read_pickle'}
ARRAY_MODULES = {'np', 'numpy', 'pd', 'pandas'}


def _file_call(func):
    """Return the name of a file-reading or -writing call, or ''."""
    if isinstance(func, ast.Name):
        return func.id if func.id == 'open' else ''
    if not isinstance(func, ast.Attribute):
        return ''
    if func.attr in ('tofile', 'to_csv', 'to_pickle', 'to_parquet'):
        return func.attr
    receiver = func.value.id if isinstance(func.value, ast.Name) else ''
    return func.attr if receiver in ARRAY_MODULES and func.attr in FILE_CALLS else ''


def file_io_uses(source, name='<source>'):
    """Return 'name:line: what' for each file-I/O import or call in Python ``source``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            mods = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            mods = [node.module]
        elif isinstance(node, ast.Call):
            called = _file_call(node.func)
            if called:
                found.append((node.lineno, f'calls {called}()'))
            continue
        else:
            continue
        found += [(node.lineno, f'imports {m}') for m in mods if m.split('.')[0] in FILE_MODULES]
    return [f'{name}:{line}: {what}' for line, what in sorted(found)]


def test_the_physics_does_no_file_io():
    uses = []
    for package in ('rod', 'model'):
        for path in sorted((PHYSICS / package).glob('*.py')):
            uses += file_io_uses(path.read_text(), f'{package}/{path.name}')
    assert uses == []


def test_the_file_io_rule_can_fail():
    source = ('import os\nimport yaml\nfrom os.path import join\nimport numpy as np\n'
              'import math\n'
              'def f(p):\n    np.savez(p, a=1)\n    with open(p) as fh:\n        return fh\n'
              'def g(p, store):\n    import pathlib\n    store.load(p)\n'
              '    return math.sqrt(np.load(p).sum())\n')
    assert file_io_uses(source) == [
        '<source>:1: imports os', '<source>:2: imports yaml', '<source>:3: imports os.path',
        '<source>:7: calls savez()', '<source>:8: calls open()',
        '<source>:11: imports pathlib', '<source>:13: calls load()']
