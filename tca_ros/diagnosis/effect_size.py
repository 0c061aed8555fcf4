"""An effect is named only where its own part of the prediction exceeds 0.5 % of the swing.

The verdict ignores what the inputs predict of a residual below a practical floor:
the larger of the noise and 0.5 % of the channel's swing (noise.structure_test). The
swing share bounds what an effect can claim too: an extension whose effect changes
the prediction by less than it once its size parameter is switched off (the rest of
the fitted values kept) has fitted a correction the verdict ignores as too small to
matter, not found an effect. A friction of 1 mN fitted jointly into a defect-free
record (seed 9600: a cst plant at 100 Hz) changed the displacement by 40 um RMS where
0.5 % of the swing was 55 um, yet tipped the residual just below the floor and was
named (docs/diagnosis_method.md, "An effect's own size").

``own_contribution`` measures that part, per channel, each record's difference less
its offset and linear drift (the verdict's nuisance), pooled over the records;
``below_floor`` lists the effects whose part stays within that share on every channel.

A lone effect's part is also what the extension changes from the calibrated nominal
model's prediction (``change_from``), the larger of the two counting: the nominal
calibration takes an effect up in shifted values, so the effect switched off with
those values kept can change little while the extension and the nominal model still
differ beyond the floor. A creep of 0.33 mm with its time constant of 30 s fitted
jointly into a drifting record (seed 9807: the truth 2.0 mm and 40 s, its first
minute crept before the record) changed the prediction by 48 um switched off, under
an 84 um floor; the extension differed from the calibrated nominal model by 130 um,
and the nominal model left structure (decisions G78).
"""
import math

import numpy as np

from tca_ros.calibration.where import detrended
from tca_ros.diagnosis.noise import STRUCTURE_FLOOR
from tca_ros.model.effects import CATALOGUE
from tca_ros.model.params_schema import SPECS


def switched_off(name):
    """Return {dotted name: value} that switches effect ``name`` off, or None.

    Its size parameter (the first the catalogue lists: a compliance, a width, an
    emissivity, a lag, a force, ...) at the schema's neutral default. None for
    coil contact, whose parameter (the pitch angle where the coils touch) is the
    muscle's geometry and has no neutral value.
    """
    size = CATALOGUE[name][0]
    return {size: SPECS[size].default} if size.startswith('effects.') else None


def own_contribution(problems, values, extendeds, name):
    """Return {channel: RMS} of what effect ``name`` adds to an extension's prediction.

    ``problems``: the diagnosis's FitProblems; ``values``: the extension's dotted
    values; ``extendeds``: its simulations at the records' samples. Per record the
    extension less the same values with ``name`` switched off, less its offset and
    linear drift; the RMS over every record's samples (channel unit: m, K, ...).
    """
    off = {**values, **switched_off(name)}
    return change_from(problems, extendeds, [p.simulate_full(off) for p in problems])


def change_from(problems, extendeds, others):
    """Return {channel: RMS} of simulations ``extendeds`` less ``others``, per channel.

    Per record of ``problems`` the difference less its offset and linear drift (the
    verdict's nuisance); the RMS over every record's samples (channel unit: m, K, ...).
    """
    out = {}
    for c in problems[0].channels:
        parts = [detrended(np.asarray(getattr(on, c), float)
                           - np.asarray(getattr(other, c), float), p.record.time)
                 for p, on, other in zip(problems, extendeds, others)]
        count = sum(part.size for part in parts)
        out[c] = math.sqrt(sum(float(part @ part) for part in parts) / count) if count else 0.0
    return out


def practical_floor(test):
    """Return the part of the floor that is no noise: a share of the swing (channel unit).

    STRUCTURE_FLOOR of the structure test ``test``'s swing: below it the verdict
    ignores a residual whatever the noise.
    """
    return STRUCTURE_FLOOR * test.swing


def below_floor(problems, stats, effects, values, extendeds, nominals=None):
    """Return [(effect, {channel: (own part, floor)})] of ``effects`` below the floor.

    ``stats``: the calibrated nominal model's {channel: ResidualStats}, whose
    structure test holds each channel's swing (channel unit). An effect is listed
    when its :func:`own_contribution` stays within :func:`practical_floor` on every
    channel. ``nominals``: the calibrated nominal model's simulations, given when
    the extension holds this one effect alone: its part is then the larger of its
    own contribution and the extension's :func:`change_from` them (module
    docstring). The noise is not the measure here: the held-out gain that took the
    effect already weighed it against the noise, and an effect can be estimated
    well below one sample's noise (a creep of 473 um RMS under 556 um of noise,
    tuned seed 9106).
    """
    out = []
    for name in effects:
        if name not in CATALOGUE or switched_off(name) is None:
            continue
        parts = own_contribution(problems, values, extendeds, name)
        if nominals is not None:
            changed = change_from(problems, extendeds, nominals)
            parts = {c: max(parts[c], changed[c]) for c in parts}
        sizes = {c: (parts[c], practical_floor(stats[c].structure)) for c in parts
                 if c in stats and stats[c].structure is not None}
        if sizes and all(part <= floor for part, floor in sizes.values()):
            out.append((name, sizes))
    return out


#: how below_floor_note ends when no effect is left named
NOMINAL_VERDICT = "; the verdict is the calibrated nominal model's"
#: how the note prints each channel (scale, unit)
PRINTED = {'displacement': (1e6, 'um'), 'temperature': (1.0, 'K'), 'force': (1e3, 'mN')}


def below_floor_note(small, kept):
    """Return the note on the effects ``below_floor`` found; ``kept``: the names still named."""
    def said(channel, part, floor):
        scale, unit = PRINTED.get(channel, (1.0, ''))
        return f'{channel} {part * scale:.3g} within {floor * scale:.3g} {unit}'.rstrip()

    parts = [f'{name} (' + ', '.join(said(c, *sizes[c]) for c in sizes) + ')'
             for name, sizes in small]
    then = f'; {" + ".join(kept)} is named' if kept else NOMINAL_VERDICT
    return ('fitted but not named: ' + '; '.join(parts) + ': switched off (a lone effect: '
            'and against the calibrated nominal model), the effect changes the prediction '
            'by no more than 0.5 % of the swing, a residual the '
            "verdict ignores (docs/diagnosis_method.md, \"An effect's own size\")" + then)
