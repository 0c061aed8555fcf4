"""Imports point one way: rod <- model <- records <- calibration <- diagnosis.

synthetic above them; toolkit beside them, on the physics only; ros and cli on top.
"""
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
             or m.startswith(('tca_ros.records', 'tca_ros.calibration', 'tca_ros.diagnosis',
                              'tca_ros.synthetic', 'tca_ros.ros', 'tca_ros.cli')))
print(','.join(bad))
"""


def test_physics_layers_import_neither_rclpy_nor_matplotlib():
    out = subprocess.run([sys.executable, '-c', CHECK], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ''


# --- packages that show the layers (issue 26) ---
PACKAGE_RANK = {'rod': 0, 'model': 1, 'records': 2, 'calibration': 3, 'diagnosis': 4,
                'synthetic': 5, 'ros': 6, 'cli': 7}
#: toolkit sits beside records..synthetic: it builds on the physics only.
TOOLKIT_MAY_IMPORT = {'rod', 'model', 'toolkit'}


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
             'tca_ros.cli.g': {'tca_ros.ros.h', 'tca_ros.model.i'}}
    assert layer_violations(graph) == ['tca_ros.model.a -> tca_ros.calibration.b',
                                       'tca_ros.ros.e -> tca_ros.cli.f',
                                       'tca_ros.toolkit.c -> tca_ros.records.d']
