"""`tca_sim score`: the scored tracking tasks, in-process or against a ROS controller.

Without ``--namespace`` the tasks run in-process with tca_pid's law (its default
gains; tca_ros.toolkit.scoring); with ``--namespace NS`` they run on the ``tca`` node
in NS against whatever controller answers there (tca_ros.cli.score_ros; rclpy is
imported only then). Both print the same table and, with ``--out DIR``, one PNG
per task.

Before each task the reference is checked against the muscle's reach at the power
limit (scoring.task_limits: the steady-state contraction at that power under the
task's load); out of reach, one warning line on stderr says so. Each row's last
column says the limits that applied: in-process, tca_pid's max_power (2 W) under
the driver's 5 W; over ROS, the node's max_power (the controller's own limit is
not known there, so the reach is an upper bound).
"""
import dataclasses
import os
import sys
import time

from tca_ros.cli.common import checked_config, InputError, warn

MAX_TIMEOUT = 3600.0  # s
STARTED_DISCOVERY = 30.0  # s a node started by --start-node may take to be discovered
EXAMPLE = """example (two tasks cut to 8 s, tca_pid's law in-process, PNGs in out/score):
  tca_sim score --config free_stroke --model cst --tasks step_up,ramp --duration 8 \\
      --out out/score"""


def add_parser(subparsers):
    """Register ``score`` on the `tca_sim` subparsers."""
    from tca_ros.cli.common import add_config_options, finite_float
    sp = subparsers.add_parser(
        'score',
        help='score a controller on the tracking tasks: tca_pid in-process, or any '
             'controller on ROS topics (--namespace)',
        description='Run the versioned tracking tasks and print one row of metrics per '
                    'task (docs/toolkit.md); each row says the power limit it ran under '
                    'and whether the reference was within reach there.', epilog=EXAMPLE)
    sp.add_argument('--tasks', default='default',
                    help="task set ('default') or comma-separated task names of it")
    sp.add_argument('--duration', type=finite_float, default=None,
                    help='cut every task to this many seconds (s; quick runs)')
    sp.add_argument('--namespace', default=None,
                    help='run over ROS on the tca node in this namespace (e.g. /finger1) '
                         'against the controller there; without it: in-process tca_pid')
    sp.add_argument('--node', default='tca', help='name of the tca node (with --namespace)')
    sp.add_argument('--start-node', action='store_true',
                    help='start tca_node in --namespace (own clock, lockstep, as fast as '
                         'possible) with --config and --model, and stop it at the end')
    sp.add_argument('--timeout', type=finite_float, default=10.0,
                    help='wall seconds without progress (no node, no controller, no '
                         'answer) before giving up with exit status 2')
    add_config_options(sp, config_help='params file (in-process and --start-node; over ROS '
                                       "the node's own parameters are used)")
    sp.add_argument('--out', default=None, help='directory (DIR) for one PNG per task')
    sp.set_defaults(func=cmd_score)


def selected_tasks(spec, duration):
    """Return the tasks named by --tasks, cut to --duration (s) when given."""
    from tca_ros.toolkit.tasks import DEFAULT_TASKS, TASK_SETS
    if spec in TASK_SETS:
        tasks = TASK_SETS[spec]
    else:
        by_name = {task.name: task for task in DEFAULT_TASKS}
        names = [name.strip() for name in spec.split(',')]
        unknown = [name for name in names if name not in by_name]
        if unknown or not names:
            raise InputError(f'--tasks = {spec!r}: unknown {unknown[0]!r}; allowed a set '
                             f'({", ".join(TASK_SETS)}) or names of '
                             f'{", ".join(by_name)}')
        tasks = tuple(by_name[name] for name in names)
    if duration is not None:
        if not 0.05 <= duration <= 1e4:
            raise InputError(f'--duration = {duration:g} s: allowed 0.05 to 1e4 s')
        tasks = tuple(dataclasses.replace(task, duration=min(task.duration, duration))
                      for task in tasks)
    return tasks


def cmd_score(args, out):
    """Run the tasks; print the score table; write the PNGs."""
    from tca_ros.toolkit.scoring import format_table
    from tca_ros.toolkit.tasks import TASKS_VERSION
    tasks = selected_tasks(args.tasks, args.duration)
    if not 0.1 <= args.timeout <= MAX_TIMEOUT:
        raise InputError(f'--timeout = {args.timeout:g} s: allowed 0.1 to {MAX_TIMEOUT:g} s')
    if args.out and os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InputError(f'--out = {args.out!r}: exists and is not a directory')
    if args.start_node and not args.namespace:
        raise InputError('--start-node needs --namespace (where to start tca_node)')
    start = time.perf_counter()
    if args.namespace:
        runs, title = _score_over_ros(args, tasks)
    else:
        runs, title = _score_in_process(args, tasks)
    wall = time.perf_counter() - start
    out.write(format_table(runs, f'{title}, tasks {TASKS_VERSION} ({wall:.1f} s wall)')
              + '\n')
    for run in runs:
        if run.get('broken'):
            out.write(f'{run["task"]}: the muscle broke (melted or the physics failed)\n')
    if args.out:
        from tca_ros.toolkit.plots import save_task_plot
        os.makedirs(args.out, exist_ok=True)
        for run in runs:
            save_task_plot(run, os.path.join(args.out, f'{run["task"]}.png'),
                           f'{title}: {run["task"]}')
        out.write(f'wrote {len(runs)} PNGs to {args.out}\n')
    return 0


def checked_limits(task, params, power_limit, source, model, rate, max_temperature):
    """Return scoring.task_limits of a task; warn on stderr when it is out of reach."""
    from tca_ros.toolkit.scoring import task_limits
    limits = task_limits(task, params, power_limit, source, model, rate, max_temperature)
    if limits['warning']:
        warn('score', limits['warning'])
    return limits


def _score_in_process(args, tasks):
    from tca_ros.params.files import load_params
    from tca_ros.ros.pid_node import PARAMETERS, PidController
    from tca_ros.toolkit.scoring import law_controller, MAX_POWER, MAX_TEMPERATURE, run_task
    params = load_params(checked_config(args.config))
    gains = {name: default for name, default, *_ in PARAMETERS if name != 'setpoint'}
    model = args.model or params.model
    factory = law_controller(lambda: PidController(**gains))
    power = min(gains['max_power'], MAX_POWER)
    source = (f'tca_pid max_power; driver {MAX_POWER:g} W' if gains['max_power'] < MAX_POWER
              else f'driver max_power; tca_pid {gains["max_power"]:g} W')
    runs = []
    for task in tasks:
        limits = checked_limits(task, params, power, source, model, 100.0, MAX_TEMPERATURE)
        run = run_task(task, params, factory, model=model)
        run['limits'] = limits
        runs.append(run)
    return runs, f'tca_pid in-process (default gains) on {params.tca_type}, {model}'


def _score_over_ros(args, tasks):
    from tca_ros.cli.score_ros import default_log_path, score_over_ros, start_node, stop_node
    namespace = '/' + args.namespace.strip('/')
    proc = None
    if args.start_node:
        proc = start_node(namespace, checked_config(args.config), args.model,
                          default_log_path(args.out), max(args.timeout, 30.0))
    try:
        # a node just started needs discovery time whatever --timeout says
        runs, values = score_over_ros(
            tasks, namespace, args.node, args.timeout,
            max(args.timeout, STARTED_DISCOVERY) if proc else None,
            before_task=lambda task, params, values: checked_limits(
                task, params, values['max_power'], "node max_power; the controller's own "
                'limit unknown', params.model, values['publish_rate'],
                values['max_temperature']))
    finally:
        if proc is not None:
            stop_node(proc)
    if not values['stamped_reference']:
        sys.stderr.write(f'tca_sim score: note: nothing in {namespace} reads the stamped '
                         'reference topic; through displacement_setpoint alone a state can '
                         'overtake its setpoint, so scores may differ between runs '
                         '(tca_pid: -p stamped_reference:=true)\n')
    return runs, (f'controller in {namespace} over ROS on {values["tca_type"]}, '
                  f'{values["model"]}')
