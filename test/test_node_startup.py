"""tca_node start-up: params files, bad parameters, several namespaced nodes at once."""
import pytest
from sensor_msgs.msg import Temperature
from std_msgs.msg import Float64

from test_node_harness import CONFIG, Probe, start_tca  # noqa: I100

pytestmark = pytest.mark.timeout(120)

BAD_STARTS = [  # (ros args, text the one-line error must hold)
    (['-p', 'fiber.radius:=0.5'], "parameter 'fiber.radius' = 0.5: must be a finite number "
                                  'in [1e-06, 0.005] m'),
    (['-p', 'publish_rate:=fast'], "parameter 'publish_rate' = 'fast'"),
    (['-p', 'melt_temperature:=150.0'], "'melt_temperature' = 150: must be above "
                                        'max_temperature (180 degC)'),
    (['-p', 'coil.min_pitch_angle_deg:=30.0'], "'coil.min_pitch_angle_deg' = 30"),
]


def test_invalid_parameters_stop_the_node_with_one_line(tmp_path):
    # All four start in parallel: each needs ~3 s of imports on this machine.
    nodes = [start_tca(tmp_path, *args, name=f'bad{i}', wait=False)
             for i, (args, _) in enumerate(BAD_STARTS)]
    try:
        for node, (_, text) in zip(nodes, BAD_STARTS):
            assert node.proc.wait(60) == 2
            log = node.log().strip()
            assert 'Traceback' not in log
            assert len(log.splitlines()) == 1, log
            assert text in log
    finally:
        for node in nodes:
            node.stop()  # a no-op for those that exited as they should


def test_int_values_in_a_params_file_are_accepted(tmp_path):
    """YAML writes 25 for 25.0: the node takes ints for double parameters."""
    text = CONFIG.read_text().replace('ambient_temperature_degc: 25.0',
                                      'ambient_temperature_degc: 25')
    assert 'ambient_temperature_degc: 25\n' in text or 'ambient_temperature_degc: 25 ' in text
    params = tmp_path / 'ints.yaml'
    params.write_text(text + '    publish_rate: 50\n')
    node = start_tca(tmp_path, params_file=params)
    try:
        assert 'publish 50 Hz' in node.log()
    finally:
        assert node.stop() == 0


def test_namespaced_nodes_run_side_by_side(tmp_path):
    names = ('finger1', 'finger2')
    nodes = [start_tca(tmp_path, '-r', f'__ns:=/{ns}', name=ns, wait=False) for ns in names]
    probe = Probe()
    try:
        for node in nodes:
            node.wait_for_log('tca node ready')
        temps = {ns: probe.record(f'/{ns}/temperature', Temperature) for ns in names}
        assert probe.spin_until(lambda: all(temps.values()), 20.0)
        for _ in range(10):  # 1 W into finger1 only, for 1 s
            probe.publish('/finger1/power_cmd', Float64(data=1.0))
            probe.spin_for(0.1)
        hot = temps['finger1'][-1][1].temperature
        cold = temps['finger2'][-1][1].temperature
        # 1 s of 1 W: T rises by 75.3 K (1 - exp(-1/3.01)) = 21 K; the other stays put.
        assert hot > 40.0
        assert cold == 25.0
    finally:
        probe.close()
        codes = [node.stop() for node in nodes]  # stop all before any assertion
    assert codes == [0, 0], [node.log() for node in nodes]


def test_use_sim_time_follows_an_external_clock(tmp_path):
    """A node with use_sim_time steps its physics on someone else's /clock."""
    source = start_tca(tmp_path, '-r', '__ns:=/source', '-p', 'publish_clock:=true',
                       '-p', 'real_time_factor:=5.0', name='source', wait=False)
    follower = start_tca(tmp_path, '-r', '__ns:=/follower', '-p', 'use_sim_time:=true',
                         name='follower', wait=False)
    probe = Probe()
    try:
        source.wait_for_log('tca node ready')
        follower.wait_for_log('tca node ready')
        temps = probe.record('/follower/temperature', Temperature)
        assert probe.spin_until(lambda: len(temps) > 20, 20.0), follower.log()
        probe.spin_for(1.0)
        stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for _, m in temps]
        wall = temps[-1][0] - temps[0][0]
        assert stamps[-1] < 600.0  # sim time from 0, not the wall clock (1.7e9 s)
        # sim time advances at real_time_factor 5: 3..7 allows for start-up jitter
        assert 3.0 < (stamps[-1] - stamps[0]) / wall < 7.0
    finally:
        probe.close()
        codes = [node.stop() for node in (follower, source)]
    assert codes == [0, 0], follower.log() + source.log()


def test_rod_model_node_settles_at_the_rod_equilibrium(tmp_path):
    """model:=rod (the Cosserat-rod table) runs in the node; a load step matches it."""
    from sensor_msgs.msg import JointState

    from tca_ros.model.dynamics import TcaSimulator
    from tca_ros.params.files import load_params

    params = load_params('free_stroke', model='rod')
    sim = TcaSimulator(params, dt=1e-3)
    load = 0.5  # N
    expected = sim.equilibrium(params.dynamics.load, 25.0) - sim.equilibrium(load, 25.0)
    node = start_tca(tmp_path, '-p', 'model:=rod', name='rod')  # the later -p wins
    probe = Probe()
    try:
        assert 'model rod' in node.log()
        joints = probe.record('joint_states', JointState)
        assert probe.spin_until(lambda: joints, 20.0)
        probe.publish('load', Float64(data=load))
        probe.spin_for(2.0)  # damping ratio ~0.3 at 27 rad/s: settled in < 1 s
        # Same table in both processes: agreement to the settling residue, 0.1 %.
        assert joints[-1][1].position[0] == pytest.approx(expected, rel=1e-3)
    finally:
        probe.close()
        assert node.stop() == 0, node.log()
