"""Score a controller on the task set, in-process against TcaSimulator.

The loop is the node's lockstep one: at each control tick t_k the controller sees
the state and the reference r(t_k) and returns a power (W), clamped to
[0, max_power] and held over [t_k, t_k+1) while the physics steps; the load
follows the task. A controller is any callable ``controller(t, setpoint, state)``
returning W, ``state`` a TcaState (displacement in ``measured_displacement``, m);
``law_controller`` wraps an object with ``update(setpoint, measurement, dt)``
(the law of tca_pid). Each task starts from the loaded equilibrium at ambient
with a fresh controller. Deterministic: same controller, same scores.

``task_limits`` says before a task whether its reference is within the muscle's
reach at the power limit: the steady-state contraction at that power under the
task's load (eq. (1) at rest, then the statics), and which limits apply.
"""
import numpy as np

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.limits import MELT_TEMPERATURE_DEGC
from tca_ros.model.simulation import static_displacement
from tca_ros.model.thermal_step import ThermalStepper
from tca_ros.toolkit.tasks import OVERHEAT_MARGIN, REFERENCE_TEMPERATURE, score

MAX_TEMPERATURE = 180.0  # degC, the node's default overheat limit
MAX_POWER = 5.0  # W, the node's default driver limit
REACH_STEPS = 8  # temperature steps of the statics' continuation from ambient to T_ss
MAX_STEADY_RISE = 5000.0  # K above ambient where the steady-state search gives up
METRICS = (('rms_error', 'mm', 1e3), ('max_error', 'mm', 1e3), ('overshoot', '%', 1.0),
           ('settling_time', 's', 1.0), ('energy', 'J', 1.0),
           ('peak_temperature', 'degC', 1.0), ('time_above_max', 's', 1.0))


def law_controller(law_factory):
    """Return a controller factory around ``law_factory()``'s update(setpoint, y, dt).

    The law gets the setpoint and measured displacement (m) and the time since its
    last call (s; 0 at the first) and returns the power (W), as tca_pid's
    PidController does.
    """
    def factory():
        law = law_factory()
        last = [None]

        def controller(t, setpoint, state):
            dt = 0.0 if last[0] is None else t - last[0]
            last[0] = t
            return law.update(setpoint, state.measured_displacement, dt)
        return controller
    return factory


def stroke_scales(params, model=None, max_temperature=MAX_TEMPERATURE):
    """Return (S, S_hot) (m): static contractions at REFERENCE_TEMPERATURE and near max."""
    p = params
    temps = [p.thermal.ambient_temperature, REFERENCE_TEMPERATURE,
             max_temperature - OVERHEAT_MARGIN]
    x = static_displacement(p, p.dynamics.load, temps, model=model)
    return float(x[1]), float(x[2])


def task_inputs(task, params, model=None, control_rate=100.0,
                max_temperature=MAX_TEMPERATURE):
    """Return (t (s), reference (m), load (N)) of a task at the control ticks.

    The stroke scales come from the statics of ``model`` (the config's by default),
    so a runner over ROS computes the very inputs the in-process one does.
    """
    dt = 1.0 / control_rate
    stroke, hot = stroke_scales(params, model, max_temperature)
    n = int(round(task.duration * control_rate))
    t = np.arange(n + 1) * dt
    return t, task.reference(t, stroke, hot), task.load(t, params.dynamics.load)


def scored_run(task, t, reference, load, displacement, temperature, power,
               max_temperature=MAX_TEMPERATURE):
    """Return the run dict (sample arrays, SI and degC) of one task with its metrics."""
    run = {'task': task.name, 'time': t, 'reference': reference, 'load': load,
           'displacement': np.asarray(displacement, dtype=float),
           'temperature': np.asarray(temperature, dtype=float),
           'power': np.asarray(power, dtype=float)}
    run['metrics'] = score(t, reference, run['displacement'], run['temperature'],
                           run['power'], max_temperature)
    return run


def steady_temperature(params, power):
    """Return the fiber temperature (degC) at rest under constant power (W).

    Eq. (1) with the thermal effects of the params (delivered-power ratio,
    radiation, nonlinear convection): where ThermalStepper.rate is zero.
    """
    from scipy.optimize import brentq
    heat = ThermalStepper(params)
    if heat.linear:
        return heat.ambient + heat.balance.gain * power / heat.balance.conductance
    top = heat.ambient + MAX_STEADY_RISE
    if power <= 0.0 or heat.rate(top, power) > 0.0:
        return heat.ambient if power <= 0.0 else top
    return brentq(lambda temp: heat.rate(temp, power), heat.ambient, top, xtol=1e-9)


def reachable_contraction(params, power, load, reference_load, model=None):
    """Return (contraction (m), temperature (degC)) at rest under power (W) and load (N).

    The contraction is read as the scorer reads it: from the loaded equilibrium at
    ambient under ``reference_load`` (N), the load a task starts with. Above the
    melt (limits.MELT_TEMPERATURE_DEGC) the muscle is taken at the melt.
    """
    km = make_kinetostatic_model(params, model)
    ambient = ThermalStepper(params).ambient
    temp = min(steady_temperature(params, power), MELT_TEMPERATURE_DEGC)
    stroke = static_displacement(params, load, np.linspace(ambient, temp, REACH_STEPS + 1),
                                 kinetostatics=km)[-1]
    stop = contact_elongation(params)
    offset = max(km.equilibrium_elongation(reference_load, ambient), stop) - max(
        km.equilibrium_elongation(load, ambient), stop)  # a heavier load starts lower
    return float(offset + stroke), temp


def task_limits(task, params, power_limit, power_source, model=None, control_rate=100.0,
                max_temperature=MAX_TEMPERATURE):
    """Return the limits a task runs under and whether its reference is within reach.

    ``power_limit`` (W) is the largest power the controller can apply and
    ``power_source`` says whose limit it is. The dict holds power_limit (W),
    power_source, max_temperature (degC, scored, not enforced), reach (m, at
    the tick where the reference is farthest beyond it), peak (m, the reference
    there), time (s), load (N), steady_temperature (degC), in_reach (bool),
    text (one table cell) and warning (one line, '' when in reach).
    """
    t, reference, load = task_inputs(task, params, model, control_rate, max_temperature)
    reach = {}
    for value in np.unique(load):
        reach[float(value)] = reachable_contraction(params, power_limit, float(value),
                                                    float(load[0]), model)
    margin = np.array([reach[float(v)][0] for v in load]) - reference
    k = int(np.argmin(margin))
    within, temp = reach[float(load[k])]
    limits = {'power_limit': power_limit, 'power_source': power_source,
              'max_temperature': max_temperature, 'reach': within, 'peak': float(reference[k]),
              'time': float(t[k]), 'load': float(load[k]), 'steady_temperature': temp,
              'in_reach': bool(margin[k] >= 0.0)}
    verdict = 'in reach' if limits['in_reach'] else 'OUT OF REACH'
    limits['text'] = (f'P <= {power_limit:g} W ({power_source}); T_max {max_temperature:g} '
                      f'degC (scored); reach {within * 1e3:.3g} mm, ref {reference[k] * 1e3:.3g}'
                      f' mm: {verdict}')
    melted = ' (at the melt)' if temp >= MELT_TEMPERATURE_DEGC else ''
    limits['warning'] = '' if limits['in_reach'] else (
        f'task {task.name}: the reference reaches {reference[k] * 1e3:.4g} mm at t = '
        f'{t[k]:.3g} s, but at the {power_limit:g} W power limit ({power_source}) under '
        f'{load[k]:.4g} N the muscle settles at {within * 1e3:.4g} mm ({temp:.4g} degC'
        f'{melted}, steady state): out of reach, expect a large error and no settling')
    return limits


def run_task(task, params, controller_factory, model=None, control_rate=100.0,
             physics_rate=1000.0, max_temperature=MAX_TEMPERATURE, max_power=MAX_POWER):
    """Run one task; return a dict of sample arrays (SI, degC) and its metrics.

    ``controller_factory()`` returns a fresh controller callable per task.
    """
    controller = controller_factory()
    dt = 1.0 / control_rate
    substeps = max(1, int(round(physics_rate / control_rate)))
    sim = TcaSimulator(params, model=model, dt=dt / substeps)
    t, reference, load = task_inputs(task, params, sim.kinetostatics.name, control_rate,
                                     max_temperature)
    n = t.size - 1
    state = sim.reset(load=load[0])
    rows = np.empty((n + 1, 3))  # displacement (m), temperature (degC), power (W)
    for k in range(n + 1):
        power = min(max(float(controller(t[k], reference[k], state)), 0.0), max_power)
        rows[k] = state.measured_displacement, state.temperature, power
        if k < n:
            for _ in range(substeps):
                state = sim.step(power, load[k])
    return scored_run(task, t, reference, load, rows[:, 0], rows[:, 1], rows[:, 2],
                      max_temperature)


def run_tasks(tasks, params, controller_factory, **options):
    """Return [run_task(...)] for each task, in order."""
    return [run_task(task, params, controller_factory, **options) for task in tasks]


def format_table(runs, title=''):
    """Return the score table of ``runs`` as Markdown (one row per task).

    Runs that carry ``limits`` (task_limits) get a last column saying the power
    limit, the overheat threshold and whether the reference was within reach.
    """
    limits = any('limits' in run for run in runs)
    head = '| task | ' + ' | '.join(f'{name} ({unit})' for name, unit, _ in METRICS) + ' |'
    head += ' limits |' if limits else ''
    rule = '|' + '---|' * (len(METRICS) + 1 + limits)
    lines = [title, '', head, rule] if title else [head, rule]
    for run in runs:
        cells = [f'{run["metrics"][name] * scale:.4g}' for name, _, scale in METRICS]
        if limits:
            cells.append(run['limits']['text'] if 'limits' in run else '-')
        lines.append(f'| {run["task"]} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)
