"""Score table of the reference controller on the default tasks (printed, not asserted).

tca_pid's law (tca_ros.ros.pid_node.PidController with its default gains, 2 W limit) against
TcaSimulator in-process, the node's lockstep loop at 100 Hz with 1 kHz physics, on the
task set of tca_ros.toolkit.tasks (version printed). With --out, one PNG per task.

Usage: python bench/bench_score.py [--config free_stroke] [--models cst,rod] [--out DIR]
"""
import argparse
import os
import time

from tca_ros.params.files import load_params
from tca_ros.ros.pid_node import PARAMETERS, PidController
from tca_ros.toolkit.scoring import format_table, law_controller, run_tasks
from tca_ros.toolkit.tasks import DEFAULT_TASKS, TASKS_VERSION


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--config', default='free_stroke', help='params file or name')
    parser.add_argument('--models', default='cst,rod', help='kinetostatic models')
    parser.add_argument('--out', default=None, help='directory for one PNG per task')
    args = parser.parse_args()
    params = load_params(args.config)
    gains = {name: default for name, default, *_ in PARAMETERS if name != 'setpoint'}
    factory = law_controller(lambda: PidController(**gains))
    for model in args.models.split(','):
        t0 = time.perf_counter()
        runs = run_tasks(DEFAULT_TASKS, params, factory, model=model)
        wall = time.perf_counter() - t0
        print(format_table(runs, f'tca_pid (kp {gains["kp"]:g} W/m, ki {gains["ki"]:g} '
                                 f'W/(m s), max {gains["max_power"]:g} W) on {args.config}, '
                                 f'{model}, tasks {TASKS_VERSION} ({wall:.1f} s wall)'))
        print()
        if args.out:
            from tca_ros.toolkit.plots import save_task_plot
            os.makedirs(args.out, exist_ok=True)
            for run in runs:
                save_task_plot(run, os.path.join(args.out, f'{model}_{run["task"]}.png'),
                               f'tca_pid, {model}: {run["task"]}')


if __name__ == '__main__':
    main()
