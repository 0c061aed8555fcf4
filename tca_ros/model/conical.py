"""The conical TCA hanging from its apex clamp: height-controlled rod statics.

Orientation (docs/rod.md, "Conical TCA"): the apex of the spiral (36) is clamped on
top, the cone opens downwards and a weight hangs from the fiber's free end, as a TCA
hangs in the paper's rigs (Fig. 4: "hanged by fixing its top"). The rod is solved in
the cone frame of Appendix C (Z up the cone axis, from the apex), in which gravity
points along +Z; the world frame (Z up) is the cone frame turned by pi about X.
The free end's drop d (m) below the clamp is the cone-frame Z of the free end; the
published end height is -d.

A dead weight on a compliant coil has several equilibria (the coils pass each
other); under a load the coil takes the one reached from the unloaded state. Force
control loses the branch at its limit points, so the branch is followed in the end
drop instead (height control, :func:`tca_ros.rod.statics.solve_rod_statics` with
``end_height``): the force F(d) comes out of each solve, and a load is inverted to
its drop on the branch followed from the unloaded state.

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (6)-(11), (17), (36)-(41), Algorithm 1.
"""
from dataclasses import dataclass
import math

import numpy as np

from tca_ros.model.limits import check_thread_strength
from tca_ros.model.rod_model import rod_reference, stiffness_vector
from tca_ros.rod.statics import solve_rod_statics

#: cone frame -> world frame (Z up): a turn by pi about X (the apex clamp on top)
HANGING = np.diag([1.0, -1.0, -1.0])
STEPS_PER_TURN = 16  # mesh of the table and statics; error vs converged in docs/rod.md
MODULI_PASSES = 4  # fixed point of Eq. (11) on the end force (1-2 passes are typical)
MODULI_TOLERANCE = 1e-6  # relative change of the moduli ending the fixed point
FIRST_STEP = 1e-3  # m, first step of the end drop along a branch
MAX_STEP = 1e-2  # m, longest step along a branch
MIN_STEP = 2e-6  # m, a branch that needs shorter steps ends there
MAX_FORCE_RATIO = 1.35  # a step may change F by at most this factor (sampling)
FORCE_FLOOR = 2e-3  # N, below which the force step is measured against this instead
EASY_ITERATIONS = 4  # Newton iterations below which the step grows
STRETCH_FORCE_RATIO = 1.1  # the stretched branch ends past this multiple of break_force


@dataclass(frozen=True)
class BranchPoint:
    """One equilibrium on a branch: drop d (m), end force F (N, tensile), solution."""

    drop: float
    force: float
    solution: object


def mesh_steps(params, temperature):
    """Return the intervals along the fiber: STEPS_PER_TURN per turn of the reference."""
    turns = rod_reference(params, temperature).n_coils
    return int(max(64, math.ceil(STEPS_PER_TURN * turns)))


def free_state(params, temperature, n_steps):
    """Return the unloaded equilibrium (RodSolution) at T (degC): the heated reference."""
    sol = solve_rod_statics(rod_reference(params, temperature),
                            stiffness_vector(params, temperature, 0.0), n_steps=n_steps)
    if not sol.success:
        raise ArithmeticError(f'conical TCA at {temperature:g} degC, no load: {sol.message}')
    return sol


def solve_at_drop(params, temperature, drop, n_steps, initial, force_guess=0.0):
    """Return the BranchPoint with the free end held at drop d (m), or None.

    The vertical end force F (N, tensile) holding it there is solved with the rod,
    the moduli of Eq. (11) taken at F itself (a fixed point, MODULI_PASSES at most).
    None when Newton fails from ``initial`` (a RodSolution or node states).
    """
    ref = rod_reference(params, temperature)
    force = float(force_guess)
    sol = None
    for _ in range(MODULI_PASSES):
        stiffness = stiffness_vector(params, temperature, force)
        sol = solve_rod_statics(ref, stiffness, n_steps=n_steps, initial=initial,
                                end_height=drop)
        if not sol.success:
            return None
        new = float(sol.end_force()[2])
        # done when the moduli at the solved force are those the solve used
        moved = np.max(np.abs(stiffness_vector(params, temperature, new) / stiffness - 1.0))
        force, initial = new, sol
        if moved <= MODULI_TOLERANCE:
            break
    return BranchPoint(float(drop), force, sol)


def follow_branch(params, temperature, n_steps, start, direction, stop):
    """Follow the equilibria from ``start`` (BranchPoint) with the drop moving.

    ``direction`` +1 lowers the end (stretching), -1 raises it. Steps adapt
    (FIRST_STEP to MAX_STEP, halved on a failed solve or a force jump, F growing by
    at most MAX_FORCE_RATIO per step); a secant predictor carries the node states.
    ``stop(point)`` ends the branch after a point. Returns the points in drop order
    of travel, ``start`` first.
    """
    points = [start]
    step = FIRST_STEP
    while step >= MIN_STEP:
        last = points[-1]
        drop = last.drop + direction * step
        guess, force = last.solution, last.force
        if len(points) > 1:
            prev = points[-2]
            ratio = step / abs(last.drop - prev.drop)
            guess = last.solution.state() + ratio * (last.solution.state()
                                                     - prev.solution.state())
            force = last.force + ratio * (last.force - prev.force)
        point = solve_at_drop(params, temperature, drop, n_steps, guess, force)
        if point is None or _jumped(points, point):
            step *= 0.5
            continue
        points.append(point)
        if stop(point):
            break
        if point.solution.n_iter < EASY_ITERATIONS:
            step = min(1.5 * step, MAX_STEP)
    return points


def _jumped(points, point):
    """Return True when ``point`` grows F by more than MAX_FORCE_RATIO (a coarse step)."""
    last = points[-1]
    scale = max(abs(last.force), FORCE_FLOOR)
    return abs(point.force - last.force) > (MAX_FORCE_RATIO - 1.0) * scale


def stretched_branch(params, temperature, n_steps=None, max_force=None):
    """Return the BranchPoints from no load down to ``max_force`` (N, tensile).

    Default max_force: STRETCH_FORCE_RATIO x fiber.break_force.
    """
    n_steps = n_steps or mesh_steps(params, temperature)
    top = (STRETCH_FORCE_RATIO * params.fiber.break_force if max_force is None
           else float(max_force))
    free = free_state(params, temperature, n_steps)
    start = BranchPoint(float(free.positions[2, -1]), 0.0, free)
    return follow_branch(params, temperature, n_steps, start, +1,
                         lambda point: point.force >= top)


def hanging_drop(params, load, temperatures, n_steps=None):
    """Return the end drop d (m) below the clamp under a hanging load (N) per T (degC).

    At each temperature the stretched branch is followed from the unloaded state
    until F passes the load, then the drop is found by the secant method on it.
    ThreadBreakError above fiber.break_force.
    """
    check_thread_strength(load, params.fiber)
    out = []
    for temp in temperatures:
        out.append(_drop_under(params, float(temp), float(load), n_steps)[0])
    return np.array(out)


def _drop_under(params, temperature, load, n_steps):
    """Return (drop (m), BranchPoint) under ``load`` (N) at ``temperature`` (degC)."""
    n_steps = n_steps or mesh_steps(params, temperature)
    free = free_state(params, temperature, n_steps)
    start = BranchPoint(float(free.positions[2, -1]), 0.0, free)
    if load == 0.0:
        return start.drop, start
    points = follow_branch(params, temperature, n_steps, start, +1,
                           lambda point: point.force >= load)
    if points[-1].force < load:
        raise ArithmeticError(f'conical TCA at {temperature:g} degC: the branch from no load '
                              f'ends at {points[-1].force:.4g} N below the load {load:g} N')
    lo, hi = points[-2], points[-1]
    for _ in range(40):
        frac = (load - lo.force) / (hi.force - lo.force)
        drop = lo.drop + frac * (hi.drop - lo.drop)
        mid = solve_at_drop(params, temperature, drop, n_steps, lo.solution,
                            lo.force + frac * (hi.force - lo.force))
        if mid is None:
            raise ArithmeticError(f'conical TCA at {temperature:g} degC under {load:g} N: '
                                  'no equilibrium between two converged drops')
        if abs(mid.force - load) <= 1e-9 + 1e-7 * load:
            return mid.drop, mid
        if mid.force < load:
            lo = mid
        else:
            hi = mid
    return mid.drop, mid


def hanging_statics(params, load, temperatures, n_steps=None):
    """Return the equilibria (BranchPoint) under a hanging load (N) per T (degC).

    Algorithm 1 of [1] with height control: at the first temperature the stretched
    branch is followed from no load to the load; each later temperature starts
    from the previous equilibrium and finds the drop where F = load by the secant
    method (safeguarded by bracketing), so heating under the weight follows its
    branch. ThreadBreakError above fiber.break_force; ArithmeticError (one line)
    where no equilibrium is found.
    """
    load = float(load)
    check_thread_strength(load, params.fiber)
    temps = [float(t) for t in temperatures]
    if not temps:
        return []
    n_steps = n_steps or mesh_steps(params, temps[0])
    out = []
    for temp in temps:
        if load == 0.0:
            free = free_state(params, temp, n_steps)
            out.append(BranchPoint(float(free.positions[2, -1]), 0.0, free))
            continue
        point = _secant_to_load(params, temp, load, n_steps, out[-1]) if out else None
        out.append(point or _drop_under(params, temp, load, n_steps)[1])
    return out


def _secant_to_load(params, temperature, load, n_steps, previous, max_iter=30):
    """Return the BranchPoint with F = load (N) near ``previous``, or None if not found."""
    a = solve_at_drop(params, temperature, previous.drop, n_steps, previous.solution, load)
    if a is None:
        return None
    step = 2e-3 if a.force < load else -2e-3
    b = solve_at_drop(params, temperature, a.drop + step, n_steps, a.solution, a.force)
    lo = hi = None
    for _ in range(max_iter):
        if b is None:
            return None
        for p in (a, b):
            if p.force <= load and (lo is None or p.drop > lo.drop):
                lo = p
            if p.force >= load and (hi is None or p.drop < hi.drop):
                hi = p
        if abs(b.force - load) <= 1e-9 + 1e-7 * load:
            return b
        slope = (b.force - a.force) / (b.drop - a.drop)
        drop = b.drop + (load - b.force) / slope if slope > 0.0 else math.nan
        if lo is not None and hi is not None and not lo.drop < drop < hi.drop:
            drop = 0.5 * (lo.drop + hi.drop)  # the secant left the bracket: bisect
        if not math.isfinite(drop) or abs(drop - b.drop) > 0.02:
            return None  # far from the previous equilibrium: follow from no load
        a, b = b, solve_at_drop(params, temperature, drop, n_steps, b.solution, load)
    return None


def world_shape(solution):
    """Return the centreline (3, n) (m) of a solution in the world frame (Z up)."""
    return HANGING @ solution.positions


def conical_shapes(params, temperatures, load=0.0, n_steps=None):
    """Return (s, xyz) per temperature: the hanging conical TCA under load (N).

    xyz (3, n) in the world frame (m): clamp at the origin, Z up, the cone hanging
    below it (docs/rod.md); s (n,) arc length (m). See :func:`hanging_statics`.
    """
    return [(p.solution.s, world_shape(p.solution))
            for p in hanging_statics(params, load, temperatures, n_steps)]


def conical_end_height(params, temperatures, load=0.0, n_steps=None):
    """Return the free end's height (m) above the clamp per temperature (Fig. 13b).

    Negative when the end hangs below the clamp; the heated coils pass each other and
    lift it above (the dual-side stroke of Sec. V-E).
    """
    return np.array([-p.drop for p in hanging_statics(params, load, temperatures, n_steps)])
