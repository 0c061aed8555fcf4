"""Jittered stamps: does the reader take the times the samples were taken at? (decisions G81)

    python bench/bench_stamps.py [--seeds 9110,9120,...] [--rates 1,2,5,20] [--latency 0.2]

Each seed's defect-free benchmark muscle (synthetic/realistic.py, a 100 Hz record at
even stamps) is sampled at each rate two ways, with the same scatter of up to
``--latency`` of a period (uniform, the first and last sample exact):

* **clock**: sampled on a steady clock, each row stamped late or early by the
  scatter (a logger whose host stamps rows as they arrive);
* **stamps**: sampled at the scattered times and stamped right (a logger that
  reads when polled).

Printed per seed and rate: stamps.clock_evidence's z for each (positive: the outputs
read smoother on the clock, which the reader then takes), and the count the reader
decides right (clock for the first, stamps for the second). Figures, not assertions.
"""
import one_blas_thread  # noqa: F401  (before NumPy: one BLAS thread per process)
import argparse  # noqa: I100, I201
import sys
import tempfile

import numpy as np

from tca_ros.records.data import read_record, Record
from tca_ros.records.stamps import clock_evidence, CLOCK_Z, slot_clock
from tca_ros.synthetic.realistic import realistic_case

#: defect-free benchmark seeds whose record is at 100 Hz with even stamps
SEEDS = (9110, 9120, 9130, 9140, 9410, 9420, 9430, 9440, 9610, 9620)


def sampled(record, rate, latency, rng):
    """Return {'clock': Record, 'stamps': Record} of ``record`` sampled at ``rate`` (Hz)."""
    k = int(round(record.sample_rate / rate))
    n = (len(record.time) - 1) // k
    base = np.arange(n) * k
    reach = int(round(latency * k))
    shift = np.r_[0, rng.integers(-reach, reach + 1, n - 2), 0]
    scattered = base + shift
    stamps = record.time[scattered]
    out = {}
    for kind, taken in (('clock', base), ('stamps', scattered)):
        temperature = None if record.temperature is None else record.temperature[taken]
        out[kind] = Record(time=stamps, power=record.power[taken], load=record.load[taken],
                           displacement=record.displacement[taken], temperature=temperature,
                           meta={'sample_rate_hz': rate})
    return out


def main(argv=None):
    """Print the evidence and the decisions; return 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', default=','.join(str(s) for s in SEEDS))
    parser.add_argument('--rates', default='1,2,5,20', help='Hz')
    parser.add_argument('--latency', type=float, default=0.2, help='of a period')
    args = parser.parse_args(argv)
    rates = [float(r) for r in args.rates.split(',')]
    rng = np.random.default_rng(5)
    right = {(r, kind): 0 for r in rates for kind in ('clock', 'stamps')}
    seeds = [int(s) for s in args.seeds.split(',')]
    print('seed   ' + ' '.join(f'{r:>5g} Hz clock/stamps z' for r in rates))
    for seed in seeds:
        with tempfile.TemporaryDirectory() as folder:
            path, _ = realistic_case(seed, [], folder)
            record = read_record(path)
        cells = []
        for rate in rates:
            zs = {}
            for kind, rec in sampled(record, rate, args.latency, rng).items():
                ticks = slot_clock(rec.time, rate)
                zs[kind] = clock_evidence(rec, ticks) if ticks is not None else float('nan')
                right[rate, kind] += (zs[kind] > CLOCK_Z) == (kind == 'clock')
            cells.append(f'{zs["clock"]:>12.1f} {zs["stamps"]:>6.1f}   ')
        print(f'{seed:<6d} ' + ' '.join(cells))
    print('decided right (of %d each): ' % len(seeds) + ', '.join(
        f'{r:g} Hz clock {right[r, "clock"]} stamps {right[r, "stamps"]}' for r in rates))
    return 0


if __name__ == '__main__':
    sys.exit(main())
