"""Style gates of ament_python packages: flake8 (ament settings) and pep257."""
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
TARGETS = ['tca_ros', 'test', 'bench', 'launch', 'setup.py']
# ament_pep257's default ignores (D100-D107: missing docstrings in magic/private places),
# plus D208 (equations are displayed indented inside docstrings, as in the paper) and
# D402 (false positives on physical words followed by brackets, e.g. 'mass (kg)').
PEP257_IGNORE = 'D100,D101,D102,D103,D104,D105,D106,D107,D203,D208,D212,D402,D404'


def _run(args):
    return subprocess.run([sys.executable, '-m', *args], cwd=ROOT, capture_output=True,
                          text=True)


def test_flake8():
    result = _run(['flake8', *[t for t in TARGETS if (ROOT / t).exists()]])
    assert result.returncode == 0, result.stdout + result.stderr


def test_pep257():
    result = _run(['pydocstyle', '--convention=pep257', f'--add-ignore={PEP257_IGNORE}',
                   'tca_ros'])
    assert result.returncode == 0, result.stdout + result.stderr
