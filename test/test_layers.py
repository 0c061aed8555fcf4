"""Imports point one way: rod <- model <- {node, diagnosis, cli}."""
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
             or m.startswith(('tca_ros.node', 'tca_ros.cli', 'tca_ros.diagnosis')))
print(','.join(bad))
"""


def test_physics_layers_import_neither_rclpy_nor_matplotlib():
    out = subprocess.run([sys.executable, '-c', CHECK], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ''
