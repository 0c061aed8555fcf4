"""What a refitted nominal says about the environment of records a calibration never saw.

A diagnosis against a calibrated params file (``--calibrated``) or the bare
description refits the nominal parameters with each effect it tries
(candidates.RECALIBRATION). A record taken in more moving air than the calibration's
(a fan, a liquid) has a shorter time constant and a lower steady rise by one factor:
eq. (1)'s loss G sets both, tau = C / G and the rise 1 / G. The refit can only move
the delivered power (the rise) and the heat capacity (tau) for it; when the two move
together, the note says so and how to tell the tools about the environment
(docs/diagnosis_method.md, "Another environment").
"""
import math

#: the steady rise and the time constant both moved by more than this factor
MOVED_FACTOR = 1.2
#: and by factors within this ratio of each other, as one heat-loss scale moves them
AGREE_FACTOR = 1.5
#: a refitted value within this factor of its range's bound is at the edge of it
EDGE_FACTOR = 1.01
RISE, CAPACITY = 'thermal.delivered_power_ratio', 'fiber.specific_heat'


def heat_loss_note(params, values, spaces):
    """Return [note] when the refit moved the steady rise and tau together, else [].

    ``params``: the nominal TcaParams; ``values``: the search's {dotted name: value}
    (the refitted nominal ones among them); ``spaces``: the refit's ParameterSpaces
    (candidates.recalibration_spaces). The factors are refitted / nominal (-); the
    heat-loss scale is 1 / sqrt(rise factor x tau factor) (-).
    """
    if RISE not in values or CAPACITY not in values:
        return []
    rise = values[RISE] / params.thermal.delivered_power_ratio
    tau = values[CAPACITY] / params.fiber.specific_heat
    together = abs(math.log(rise / tau)) <= math.log(AGREE_FACTOR)
    faster = max(rise, tau) < 1.0 / MOVED_FACTOR
    slower = min(rise, tau) > MOVED_FACTOR
    if not together or not (faster or slower):
        return []
    scale = 1.0 / math.sqrt(rise * tau)
    edge = any(values[s.name] <= s.low * EDGE_FACTOR or values[s.name] >= s.high / EDGE_FACTOR
               for s in spaces if s.name in (RISE, CAPACITY))
    return [f'the refitted nominal parameters take the steady rise to x{rise:.2f} and the time '
            f'constant to x{tau:.2f} of the nominal model together, as a heat loss about '
            f'{scale:.2g}x the nominal one would'
            + (' (at the edge of their refit range: the change may be larger)' if edge else '')
            + ': if these records were taken in '
            + ('more moving air or a liquid' if faster else 'stiller air or an enclosure')
            + " than the nominal model's, name that environment in their header "
              '(`# environment: forced_air`, `water` or any name) so that calibrate and '
              'validate give it a heat-loss scale of its own (docs/calibration.md, '
              '"Conditions: environment and strength")']
