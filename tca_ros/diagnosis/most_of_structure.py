"""Effects that take away most of the structure are a cause, though structure remains.

The verdict is 'unexplained' while the inputs still predict a practically relevant
part of the held-out residual (noise.structure_test), and the search's effects
are then shown as helpful, not named: an effect that improves the fit a little
beside a defect the catalogue lacks stands in for it. That is how the effects
tried against a sensor nonlinearity or a fatigue behave: they leave 67 % to 95 %
of the predictable part the nominal model left.

A cause the catalogue has leaves far less. A dead time of 1.59 s in a rod plant at
5 Hz described with the cst model (seed 9841) was fitted at 1.60 s; the part of
the displacement residual the inputs predict fell from 3.6 mm to 0.37 mm, the
temperature's from 21 K to 0.56 K, and what remained (0.8 % of a 46 mm swing) is
the kinetostatic model's difference from the plant's. So an extension whose
predictable part is at most ``MOST_SHARE`` of the nominal model's on every channel
either leaves structured (in variance: at least 90 % of the predictable part taken
away) is named, the verdict still 'unexplained', saying something else acts too
(decisions G91).
"""
import math

#: an extension leaving at most this share of the nominal model's predictable
#: residual (RMS; 10 % of its variance) on every structured channel names its effects
MOST_SHARE = math.sqrt(0.1)


def predictable(stats):
    """Return {channel: RMS of the held-out residual the inputs predict} (channel units)."""
    return {c: st.structure.predictable_rms for c, st in stats.items()
            if st.structure is not None}


def takes_most_of_structure(nominal_stats, stats):
    """Return True when ``stats`` leave at most MOST_SHARE of ``nominal_stats``' structure.

    ``nominal_stats``, ``stats``: {channel: ResidualStats} on the held-out part of
    the calibrated nominal model and of the extension. Every channel structured in
    either must have its predictable RMS (channel units) cut to MOST_SHARE of the
    nominal model's or less; False when the nominal model leaves no held-out
    channel structured (nothing there to take).
    """
    before, after = predictable(nominal_stats), predictable(stats)
    channels = [c for c in before if c in after
                and (nominal_stats[c].structured or stats[c].structured)]
    if not any(nominal_stats[c].structured for c in channels):
        return False
    return all(after[c] <= MOST_SHARE * before[c] for c in channels)


def most_of_structure_text(nominal_stats, stats, n_effects=1):
    """Return the clause naming ``n_effects`` effects by the share of structure taken away."""
    before, after = predictable(nominal_stats), predictable(stats)
    shares = ', '.join(f'{c} {100.0 * (1.0 - (after[c] / before[c]) ** 2):.0f} %'
                       for c in before if c in after and before[c] > 0.0)
    subject = 'it takes' if n_effects == 1 else 'they take'
    return (f'{subject} away at least 90 % of the held-out residual the inputs predicted '
            f'beside the calibrated nominal model ({shares} of its variance; '
            'docs/diagnosis_method.md, "Most of the structure")')
