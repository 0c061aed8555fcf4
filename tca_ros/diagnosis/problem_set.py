"""Several records of one muscle as one fitting problem (``diagnose REC [REC ...]``).

Each record keeps its own FitProblem (its grid, its split in time, its mass and
initial load, its defect correction); the effect parameters are shared. The
training residuals of all records are stacked channel by channel (so a
per-channel cost still reads as one block per channel) and the held-out costs
are summed: the search (search.search_effects) sees one problem.
"""
import numpy as np

from tca_ros.diagnosis.fitting import FAILED_RESIDUAL, FitProblem


class FitProblemSet(FitProblem):
    """A list of FitProblems with shared effect values (same channels in each)."""

    def __init__(self, problems):  # noqa: D107 -- documented on the class
        if not problems:
            raise ValueError('a problem set needs at least one record')
        self.problems = list(problems)
        first = self.problems[0]
        self.channels = list(first.channels)
        for p in self.problems[1:]:
            if list(p.channels) != self.channels:
                raise ValueError('every record of a set must carry the same channels '
                                 f'({", ".join(self.channels)})')
        self.progress = first.progress
        self.model = first.model
        self.params = first.params
        self.record = first.record
        self.sample_rate = first.sample_rate
        self.sigma = first.sigma
        self.recalibration = ()

    @property
    def base_values(self):
        """Return the shared base values (dotted name -> schema units)."""
        return self.problems[0].base_values

    @base_values.setter
    def base_values(self, values):
        for p in self.problems:
            p.base_values = dict(values)

    @property
    def stop_moves(self):
        """Return True while a fit moves the coil stop (every record runs full)."""
        return self.problems[0].stop_moves

    @stop_moves.setter
    def stop_moves(self, flag):
        for p in self.problems:
            p.stop_moves = flag

    def parameters(self, values):
        """Return the first record's params with ``values`` applied."""
        return self.problems[0].parameters(values)

    def set_base(self, values):
        """Make ``values`` the base of every record; return the list of full simulations."""
        return [p.set_base(values) for p in self.problems]

    def simulate_full(self, values):
        """Return the record-rate SimulationResult of every record (list)."""
        return [p.simulate_full(values) for p in self.problems]

    def train_residuals(self, values):
        """Return the stacked training residuals (-): channel by channel, records inside."""
        parts = [p.train_residuals(values).reshape(len(self.channels), -1)
                 for p in self.problems]
        return np.concatenate([np.concatenate([part[i] for part in parts])
                               for i in range(len(self.channels))])

    def heldout_residuals(self, values):
        """Return [{channel: residual}] on the coarse held-out runs of every record, or None."""
        out = []
        for p in self.problems:
            part = p.heldout_residuals(values)
            if part is None:
                return None
            out.extend(part)
        return out

    @property
    def coarse_rates(self):
        """Return [coarse-grid rate (Hz)] per held-out run of every record."""
        return [r for p in self.problems for r in p.coarse_rates]

    @property
    def heldout_starts(self):
        """Return [time (s) of each held-out run's start since its record's zero]."""
        return [t for p in self.problems for t in p.heldout_starts]

    @property
    def heldout_groups(self):
        """Return [key of the record] per held-out run of every record."""
        return [g for p in self.problems for g in p.heldout_groups]

    def heldout(self, values):
        """Return (cost, {channel: RMSE}, n, mean lag-1 autocorrelation) over the records."""
        cost, n, rhos, sq, counts = 0.0, 0, [], {}, {}
        for p in self.problems:
            c, rmse, k, rho = p.heldout(values)
            cost += c
            n += k
            rhos.append(rho)
            m = p.heldout_index.size
            for ch, v in rmse.items():
                sq[ch] = sq.get(ch, 0.0) + v * v * m
                counts[ch] = counts.get(ch, 0) + m
        if not np.isfinite(cost):
            cost = FAILED_RESIDUAL ** 2 * n
        rmse = {ch: float(np.sqrt(sq[ch] / counts[ch])) for ch in sq}
        return cost, rmse, n, float(np.mean(rhos))
