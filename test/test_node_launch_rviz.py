"""The shipped launch file and RViz config agree with the node they start and show.

launch and launch_ros are not on PyPI: the launch description itself is built only where
they are installed. Everywhere, the launch file is compiled, its tables are imported
(its launch imports are inside ``generate_launch_description``) and checked against the
node's own names, and the RViz config is checked against two real nodes started in the
launch file's namespaces with its params files.
"""
import importlib.util
import py_compile

import pytest
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from visualization_msgs.msg import Marker
import yaml

from tca_ros.ros.node_params import namespaced_name, NODE_SPECS

from test_node_harness import Probe, ROOT, start_tca  # noqa: I100

pytestmark = pytest.mark.timeout(120)

LAUNCH = ROOT / 'launch' / 'two_muscles.launch.py'
RVIZ = ROOT / 'rviz' / 'tca.rviz'
MARKER_TYPE = 'visualization_msgs/msg/Marker'
#: RViz2's names of the QoS policies a display asks for.
RVIZ_RELIABILITY = {'Reliable': ReliabilityPolicy.RELIABLE,
                    'Best Effort': ReliabilityPolicy.BEST_EFFORT}
RVIZ_DURABILITY = {'Volatile': DurabilityPolicy.VOLATILE,
                   'Transient Local': DurabilityPolicy.TRANSIENT_LOCAL}


def _launch_module():
    spec = importlib.util.spec_from_file_location('two_muscles_launch', LAUNCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _displays(config, kind):
    return [d for d in config['Visualization Manager']['Displays']
            if d['Class'] == f'rviz_default_plugins/{kind}']


def _argument(args, flag):
    return args[args.index(flag) + 1]


def test_launch_file_compiles(tmp_path):
    py_compile.compile(str(LAUNCH), cfile=str(tmp_path / 'launch.pyc'), doraise=True)


def test_launch_file_places_the_clamp_frame_each_node_uses():
    launch = _launch_module()
    namespaces = [namespace for namespace, _, _ in launch.MUSCLES]
    assert len(namespaces) >= 2 and len(set(namespaces)) == len(namespaces)
    assert len({x for _, _, x in launch.MUSCLES}) == len(namespaces), 'muscles overlap'
    for namespace, params_file, x in launch.MUSCLES:
        assert (ROOT / 'config' / params_file).is_file(), params_file
        args = launch.static_transform_arguments(namespace, x)
        assert _argument(args, '--child-frame-id') == namespaced_name(
            f'/{namespace}', NODE_SPECS['base_frame'].default)
        assert _argument(args, '--frame-id') == launch.WORLD_FRAME
        assert float(_argument(args, '--x')) == x
    assert (ROOT / 'rviz' / launch.RVIZ_CONFIG).is_file()


def _have(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


@pytest.mark.skipif(not _have('launch', 'launch_ros'),
                    reason='launch and launch_ros come with a ROS install, not from PyPI')
def test_generate_launch_description(tmp_path, monkeypatch):
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch_ros.actions import Node
    marker = tmp_path / 'share' / 'ament_index' / 'resource_index' / 'packages' / 'tca_ros'
    marker.parent.mkdir(parents=True)
    marker.touch()  # get_package_share_directory('tca_ros') -> tmp_path/share/tca_ros
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    launch = _launch_module()
    description = launch.generate_launch_description()
    assert isinstance(description, LaunchDescription)
    arguments = [e.name for e in description.entities if isinstance(e, DeclareLaunchArgument)]
    assert arguments == ['rviz']
    nodes = [(e.node_package, e.node_executable) for e in description.entities
             if isinstance(e, Node)]
    n = len(launch.MUSCLES)
    assert sorted(nodes) == sorted([('tca_ros', 'tca_node')] * n + [
        ('tf2_ros', 'static_transform_publisher')] * n + [('rviz2', 'rviz2')])


def test_rviz_config_shows_the_nodes_the_launch_file_starts(tmp_path):
    launch = _launch_module()
    config = yaml.safe_load(RVIZ.read_text())
    assert config['Visualization Manager']['Global Options']['Fixed Frame'] == \
        launch.WORLD_FRAME
    assert [d['Enabled'] for d in _displays(config, 'TF')] == [True]
    displays = _displays(config, 'Marker')
    assert displays and all(d['Enabled'] for d in displays)
    topics = [d['Topic']['Value'] for d in displays]
    nodes = [start_tca(tmp_path, '-r', f'__ns:=/{namespace}', '-p', 'shape_rate:=10.0',
                       '-p', 'shape_points:=20', name=namespace,
                       params_file=ROOT / 'config' / params_file)
             for namespace, params_file, _ in launch.MUSCLES]
    probe = Probe()
    try:
        published = {}

        def discovered():
            for namespace, _, _ in launch.MUSCLES:
                try:
                    names = probe.get_publisher_names_and_types_by_node('tca', f'/{namespace}')
                except Exception:  # noqa: B902  not discovered yet
                    return False
                published[namespace] = {t for t, types in names if MARKER_TYPE in types}
            return all(published.values())

        assert probe.spin_until(discovered, 30.0), published
        # one Marker display per muscle, on the Marker topic its node really publishes
        assert sorted(topics) == sorted(t for ts in published.values() for t in ts)
        for display in displays:
            asked = display['Topic']
            (writer,) = probe.get_publishers_info_by_topic(asked['Value'])
            qos = writer.qos_profile
            if RVIZ_RELIABILITY[asked['Reliability Policy']] == ReliabilityPolicy.RELIABLE:
                assert qos.reliability == ReliabilityPolicy.RELIABLE, asked['Value']
            if RVIZ_DURABILITY[asked['Durability Policy']] == DurabilityPolicy.TRANSIENT_LOCAL:
                assert qos.durability == DurabilityPolicy.TRANSIENT_LOCAL, asked['Value']
        # each Marker is drawn in the frame the launch file places in the Fixed Frame
        rows = {topic: probe.record(topic, Marker) for topic in topics}
        assert probe.spin_until(lambda: all(rows.values()), 30.0), \
            {t: len(r) for t, r in rows.items()}
        clamps = {_argument(launch.static_transform_arguments(namespace, x),
                            '--child-frame-id') for namespace, _, x in launch.MUSCLES}
        assert {r[-1][1].header.frame_id for r in rows.values()} == clamps
    finally:
        probe.close()
        for node in nodes:
            assert node.stop() == 0, node.log()
