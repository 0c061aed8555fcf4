"""A diagnosis of repeated runs sets its residual beside the spread between the runs."""
import numpy as np

from tca_ros.diagnosis.identification import repeat_notes
from tca_ros.records.data import Record


def _run(offset, power=1.0, load=0.098):
    t = np.linspace(0.0, 60.0, 301)
    stroke = 0.01 * (1.0 - np.exp(-t / 5.0)) + offset
    return Record(time=t, power=np.full_like(t, power), load=np.full_like(t, load),
                  displacement=stroke, meta={}, source=f'{offset}')


def test_the_residual_is_compared_with_the_spread_of_repeats():
    # two runs 2 mm apart: each differs from the other (its repeats' mean) by 2 mm RMS
    runs = [_run(0.0), _run(0.002)]
    below = repeat_notes(runs, {'displacement': 0.0005})
    assert len(below) == 1 and 'is below the spread' in below[0] and '(2 mm' in below[0]
    above = repeat_notes(runs, {'displacement': 0.004})
    assert 'is above the spread' in above[0] and 'misses more' in above[0]


def test_records_without_repeats_get_no_note():
    # another power is another condition: no repeats, nothing to compare
    assert repeat_notes([_run(0.0), _run(0.002, power=2.0)], {'displacement': 0.001}) == []
    assert repeat_notes([_run(0.0)], {'displacement': 0.001}) == []
