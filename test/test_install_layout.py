"""colcon build gives the layout `ros2 run tca_ros tca_node` needs (see ros_on_pypi.md)."""
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

from test_node_harness import NodeProcess, ROOT  # noqa: I100

pytestmark = pytest.mark.timeout(120)

COLCON = pathlib.Path(sys.executable).with_name('colcon')


@pytest.fixture(scope='module')
def install(tmp_path_factory):
    if not COLCON.exists():
        pytest.skip('colcon is not installed in this environment')
    base = tmp_path_factory.mktemp('colcon')
    result = subprocess.run(
        [str(COLCON), 'build', '--paths', str(ROOT), '--packages-select', 'tca_ros',
         '--build-base', str(base / 'build'), '--install-base', str(base / 'install')],
        cwd=base, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=90)
    assert result.returncode == 0, result.stdout
    yield base / 'install' / 'tca_ros'
    shutil.rmtree(base, ignore_errors=True)


def test_executables_marker_and_manifest_are_installed(install):
    for exe in ('tca_node', 'tca_pid', 'tca_sim'):
        path = install / 'lib' / 'tca_ros' / exe
        assert path.is_file() and os.access(path, os.X_OK), exe
    assert (install / 'share' / 'ament_index' / 'resource_index' / 'packages'
            / 'tca_ros').is_file()
    assert (install / 'share' / 'tca_ros' / 'package.xml').is_file()
    assert (install / 'share' / 'tca_ros' / 'config' / 'free_stroke.yaml').is_file()


def test_launch_file_and_rviz_config_are_installed(install):
    """`ros2 launch tca_ros two_muscles.launch.py` finds them in share/tca_ros."""
    for shipped in ('launch/two_muscles.launch.py', 'rviz/tca.rviz'):
        installed = install / 'share' / 'tca_ros' / shipped
        assert installed.is_file(), shipped
        assert installed.read_bytes() == (ROOT / shipped).read_bytes(), shipped


def test_installed_tca_node_runs_as_ros2_run_would(install, tmp_path):
    """Resolve tca_ros in the ament index as `ros2 run` does, then run lib/tca_ros/tca_node."""
    env = os.environ.copy()
    env['AMENT_PREFIX_PATH'] = str(install)
    site = next((install / 'lib').glob('python3*/site-packages'))
    env['PYTHONPATH'] = os.pathsep.join([str(site), env.get('PYTHONPATH', '')])
    lookup = subprocess.run(
        [sys.executable, '-c', 'from ament_index_python.packages import get_package_prefix;'
         "print(get_package_prefix('tca_ros'))"], env=env, capture_output=True, text=True)
    assert lookup.stdout.strip() == str(install), lookup.stderr
    exe = pathlib.Path(lookup.stdout.strip()) / 'lib' / 'tca_ros' / 'tca_node'
    config = install / 'share' / 'tca_ros' / 'config' / 'free_stroke.yaml'
    node = NodeProcess([exe, '--ros-args', '--params-file', config, '-p', 'model:=cst'],
                       tmp_path / 'installed.log', env=env, cwd=tmp_path)
    try:
        node.wait_for_log('tca node ready')
    finally:
        assert node.stop() == 0, node.log()


def test_setup_bash_puts_the_package_on_the_ament_path(install):
    """README 'For ROS users': colcon-bash writes install/setup.bash; sourcing it works."""
    setup = install.parent / 'setup.bash'
    assert setup.is_file(), 'no install/setup.bash: colcon-bash missing (requirements.txt)'
    env = os.environ.copy()
    env['AMENT_PREFIX_PATH'] = str(pathlib.Path(sys.prefix))  # the underlay: the venv
    result = subprocess.run(
        ['bash', '-c', f'set +u; source {setup} && echo "$AMENT_PREFIX_PATH"'],
        env=env, capture_output=True, text=True, timeout=30)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().split(':') == [str(install), sys.prefix], result.stdout
