"""Closed-loop demo: tca_node + tca_pid over ROS 2 topics, in lockstep with /clock.

``run_demo(out_dir)`` starts the simulator (owning the time, as fast as the loop allows)
and the PID controller as subprocesses on a private ROS domain, sends a displacement
setpoint profile, records the feedback, writes ``out_dir/demo_tracking.png`` (setpoint
vs displacement, temperature, power) and prints a summary table.

This module starts rclpy (lazily, inside run_demo) to record the topics; the physics
layers stay free of it.
"""
import math
import os
import pathlib
import random
import subprocess
import sys
import time

from tca_ros.cli.common import stop_gracefully

STOP_GRACE = 5.0  # s between SIGINT and SIGKILL for the demo's processes
START_TIMEOUT = 120.0  # s of wall time for the nodes to start (rod table ~2 s)

#: Setpoint profile: (start as a fraction of the run, displacement setpoint in m).
PROFILE = ((0.0, 0.0), (1.0 / 30.0, 0.002), (10.0 / 30.0, 0.004), (18.0 / 30.0, 0.001),
           (24.0 / 30.0, None))  # None: a 2.5 +- 1 mm sine of period SINE_PERIOD
SINE_PERIOD = 3.0  # s
SINE_MEAN, SINE_AMPLITUDE = 0.0025, 0.001  # m


def setpoint_at(t, sim_seconds):
    """Return the demo's displacement setpoint (m) at sim time t (s)."""
    value = 0.0
    for start, level in PROFILE:
        if t >= start * sim_seconds:
            value = level
            t0 = start * sim_seconds
    if value is None:
        return SINE_MEAN + SINE_AMPLITUDE * math.sin(2.0 * math.pi * (t - t0) / SINE_PERIOD)
    return value


def _start(module, ros_args, log_path, env):
    log = open(log_path, 'w')
    proc = subprocess.Popen([sys.executable, '-m', module, '--ros-args', *ros_args],
                            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            env=env)
    return proc, log


def _stop(proc, log):
    stop_gracefully(proc, STOP_GRACE)
    log.close()


def run_demo(out_dir, sim_seconds=30.0, config='free_stroke', model=None):
    """Run simulator + controller for sim_seconds (s) of sim time; return a summary dict.

    Parameters
    ----------
    out_dir : str or path
        Where demo_tracking.png and the two node logs are written.
    sim_seconds : float
        Simulated duration (s).
    config : str
        Params file path or shipped name (config/*.yaml).
    model : str, optional
        rod | cst | love; default the params file's (cst when rod is not installed).
    """
    from tca_ros.params.config_search import resolve_config
    from tca_ros.params.files import load_params

    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = resolve_config(config)
    model = model or load_params(path).model
    env = os.environ.copy()
    env['ROS_DOMAIN_ID'] = str(random.randint(150, 200))  # private graph for the demo
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    saved = {k: os.environ.get(k) for k in ('ROS_AUTOMATIC_DISCOVERY_RANGE',)}
    os.environ.update({k: env[k] for k in saved})  # the recorder stays on this host
    try:
        return _run(out, path, model, sim_seconds, env)
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _run(out, path, model, sim_seconds, env):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import Float64

    from tca_ros.ros.node_schema import NODE_SPECS

    # An own context on the demo's private domain: a caller's rclpy stays untouched.
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(env['ROS_DOMAIN_ID']))
    recorder = rclpy.create_node('tca_demo_recorder', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(recorder)
    qos = QoSProfile(depth=1000)
    rows = {'joint': [], 'temperature': [], 'power': []}
    reference_pub = recorder.create_publisher(JointState, 'reference', QoSProfile(depth=10))
    reference = JointState(name=[NODE_SPECS['joint_name'].default], position=[0.0])

    def on_joint(msg):
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        sp = setpoint_at(t, sim_seconds)
        if not rows['joint'] or t > rows['joint'][-1][0]:  # the first state may repeat
            rows['joint'].append((t, msg.position[0], sp))
        # the setpoint of this state, under its stamp: tca_pid (stamped_reference) waits
        # for it, so the loop does not run ahead of this recorder (a setpoint that arrived
        # late, under load, made the tracking error vary between runs)
        reference.header.stamp = msg.header.stamp
        reference.position[0] = sp
        reference_pub.publish(reference)

    def on_temperature(msg):
        t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        if not rows['temperature'] or t > rows['temperature'][-1][0]:
            rows['temperature'].append((t, msg.temperature))

    def on_power(msg):  # unstamped: file it under the latest state's time
        t = rows['joint'][-1][0] if rows['joint'] else 0.0
        if rows['power'] and rows['power'][-1][0] == t:
            rows['power'][-1] = (t, msg.data)
        else:
            rows['power'].append((t, msg.data))

    recorder.create_subscription(JointState, 'joint_states', on_joint, qos)
    recorder.create_subscription(Temperature, 'temperature', on_temperature, qos)
    recorder.create_subscription(Float64, 'power', on_power, qos)

    # In lockstep the simulator repeats its first state until a command arrives, and the
    # controller (wait_for_setpoint, stamped_reference) answers a state only with the
    # setpoint of its stamp, which this recorder sends on every state it receives: each
    # tick waits for the whole loop, so two runs give the same tracking error.
    # tca_pid takes its time from the state's stamps: without use_sim_time it reads no
    # /clock, one message less per tick (docs/node_figures.md, lockstep speed).
    pid = _start('tca_ros.ros.pid_node', ['-p', 'wait_for_setpoint:=true',
                                          '-p', 'stamped_reference:=true'],
                 out / 'demo_pid.log', env)
    tca = _start('tca_ros.ros.node', ['--params-file', path, '-p', f'model:={model}',
                                      '-p', 'publish_clock:=true', '-p', 'real_time_factor:=0.0',
                                      '-p', 'lockstep:=true'], out / 'demo_tca.log', env)
    wall0 = time.monotonic()
    try:
        deadline = wall0 + START_TIMEOUT + 10.0 * sim_seconds
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
            if rows['joint'] and rows['joint'][-1][0] >= sim_seconds:
                break
            if tca[0].poll() is not None or pid[0].poll() is not None:
                break
        wall = time.monotonic() - wall0
    finally:
        _stop(*pid)
        _stop(*tca)
        executor.remove_node(recorder)
        recorder.destroy_node()
        rclpy.try_shutdown(context=context)
    if not rows['joint'] or rows['joint'][-1][0] < sim_seconds:
        raise RuntimeError(f'demo: the simulation stopped early; see {out}/demo_tca.log and '
                           f'{out}/demo_pid.log')
    summary = _summarize(rows, sim_seconds, wall, model)
    summary['figure'] = str(_plot(rows, out / 'demo_tracking.png', model))
    return summary


def _summarize(rows, sim_seconds, wall, model):
    import numpy as np

    t, y, sp = (np.array(c) for c in zip(*rows['joint']))
    tt, temp = (np.array(c) for c in zip(*rows['temperature']))
    temp_at = np.interp(t, tt, temp)  # same stamps; interp guards a missed sample
    power = np.array([value for _, value in rows['power']])
    error = y - sp
    print(f'TCA closed-loop demo: model {model}, {sim_seconds:g} s simulated in {wall:.1f} s '
          f'wall ({sim_seconds / wall:.1f}x real time)')
    print(f'{"segment (s)":>14s} {"setpoint (mm)":>14s} {"rms error (mm)":>15s} '
          f'{"end error (mm)":>15s} {"max T (degC)":>13s}')
    edges = [start * sim_seconds for start, _ in PROFILE] + [sim_seconds]
    segments = []
    for (start, level), t0, t1 in zip(PROFILE, edges[:-1], edges[1:]):
        m = (t >= t0) & (t < t1)
        if not m.any():
            continue
        label = 'sine' if level is None else f'{1e3 * level:.1f}'
        rms = float(np.sqrt(np.mean(error[m] ** 2)))
        end = float(error[m][-1])
        tmax = float(temp_at[m].max())
        segments.append({'start': t0, 'end': t1, 'setpoint': label, 'rms_error': rms,
                         'end_error': end, 'max_temperature': tmax})
        print(f'{t0:6.1f}-{t1:6.1f} {label:>14s} {1e3 * rms:15.3f} {1e3 * end:15.3f} '
              f'{tmax:13.1f}')
    overall = float(np.sqrt(np.mean(error ** 2)))
    print(f'overall rms error {1e3 * overall:.3f} mm; max temperature {temp.max():.1f} degC; '
          f'mean power {power.mean():.3f} W')
    return {'model': model, 'sim_seconds': sim_seconds, 'wall_seconds': wall,
            'rms_error': overall, 'max_temperature': float(temp.max()),
            'mean_power': float(power.mean()), 'segments': segments}


def _plot(rows, path, model):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    t, y, sp = (np.array(c) for c in zip(*rows['joint']))
    tt, temp = (np.array(c) for c in zip(*rows['temperature']))
    tp, power = (np.array(c) for c in zip(*rows['power']))
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 7))
    axes[0].plot(t, 1e3 * sp, 'k--', label='setpoint')
    axes[0].plot(t, 1e3 * y, label='displacement')
    axes[0].set_ylabel('contraction (mm)')
    axes[0].legend(loc='upper right')
    axes[0].set_title(f'tca_node ({model}) + tca_pid in lockstep over ROS 2 topics')
    axes[1].plot(tt, temp, color='tab:red')
    axes[1].set_ylabel('temperature (degC)')
    axes[2].step(tp, power, where='post', color='tab:orange')
    axes[2].set_ylabel('power (W)')
    axes[2].set_xlabel('sim time (s)')
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


if __name__ == '__main__':
    run_demo(sys.argv[1] if len(sys.argv) > 1 else 'out')
