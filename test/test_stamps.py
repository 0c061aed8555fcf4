"""Jittered stamps: a steady clock read with a latency, or samples taken at their stamps."""
import io

import numpy as np
import pytest

from tca_ros.cli.main import main
from tca_ros.records.data import read_record, Record, uniform_record, write_csv_record
from tca_ros.records.stamps import clock_evidence, slot_clock

RATE = 5.0  # Hz
SPAN = 120.0  # s


def response(t):
    """Return a stroke (m) heated 10 s and cooled 10 s in turn, time constant 2 s."""
    phase = np.mod(t, 20.0)
    rise = 2e-3 * (1.0 - np.exp(-np.minimum(phase, 10.0) / 2.0))
    return np.where(phase < 10.0, rise, rise * np.exp(-(phase - 10.0) / 2.0))


def record_of(sample_times, stamps, seed=0):
    """Return a Record of the response sampled at ``sample_times``, stamped ``stamps`` (s)."""
    noise = 5e-6 * np.random.default_rng(seed).standard_normal(sample_times.size)
    power = np.where(np.mod(sample_times, 20.0) < 10.0, 1.0, 0.0)
    return Record(time=stamps, power=power, load=np.full_like(stamps, 0.2),
                  displacement=response(sample_times) + noise,
                  meta={'sample_rate_hz': RATE, 'tca': 'free_stroke', 'mass_kg': 0.02})


def scatter(n, seed=1):
    """Return latencies of up to 20 % of a period (s), the first and last none."""
    late = np.random.default_rng(seed).uniform(-0.2, 0.2, n) / RATE
    late[[0, -1]] = 0.0
    return late


def test_a_clock_read_with_a_stamping_latency_is_read_on_the_clock():
    clock = np.arange(int(SPAN * RATE)) / RATE
    rec = record_of(clock, clock + scatter(clock.size))
    out = uniform_record(rec)
    # the samples themselves, on the clock: nothing interpolated
    np.testing.assert_allclose(out.time, clock, atol=1e-9)
    np.testing.assert_array_equal(out.displacement, rec.displacement)
    assert len(out.reading) == 1 and 'samples taken on the clock' in out.reading[0]
    assert 'up to 20 % of a period around a steady 5 Hz clock' in out.reading[0]
    z = clock_evidence(rec, slot_clock(rec.time, RATE))
    assert z > 2.0 and f'z = {z:.1f}' in out.reading[0]


def test_samples_taken_at_irregular_times_keep_their_stamps():
    clock = np.arange(int(SPAN * RATE)) / RATE
    taken = clock + scatter(clock.size)
    rec = record_of(taken, taken)
    out = uniform_record(rec)
    assert len(out.reading) == 1 and 'samples taken at their stamps' in out.reading[0]
    assert clock_evidence(rec, slot_clock(rec.time, RATE)) < -2.0
    # interpolated from the stamps onto the grid: the response there, within the noise
    # and the linear interpolation of a 2 s exponential over 0.2 s
    inner = out.displacement[1:-1] - response(out.time[1:-1])
    assert np.sqrt(np.mean(inner ** 2)) < 2e-5
    # read on the clock instead, each sample would sit up to 40 ms from its time
    misplaced = rec.displacement[1:-1] - response(clock[1:-1])
    assert np.sqrt(np.mean(misplaced ** 2)) > 1.5 * np.sqrt(np.mean(inner ** 2))


def test_a_lost_sample_stays_a_gap_on_the_clock():
    clock = np.arange(int(SPAN * RATE)) / RATE
    rec = record_of(clock, clock + scatter(clock.size))
    keep = np.ones(clock.size, bool)
    keep[100] = False  # the logger lost the sample at 20 s
    lost = Record(time=rec.time[keep], power=rec.power[keep], load=rec.load[keep],
                  displacement=rec.displacement[keep], meta=rec.meta)
    ticks = slot_clock(lost.time, RATE)
    np.testing.assert_allclose(np.diff(ticks)[99], 2.0 / RATE, rtol=1e-3)
    out = uniform_record(lost)
    np.testing.assert_allclose(out.time, clock, atol=1e-9)
    np.testing.assert_allclose(out.displacement[keep], rec.displacement[keep], atol=1e-12)
    # the lost sample is its neighbours' mean, as on any gap
    assert out.displacement[100] == pytest.approx(
        0.5 * (rec.displacement[99] + rec.displacement[101]), abs=1e-12)


def test_stamps_of_no_steady_clock_are_kept_without_a_note():
    # the logger slowed from 5 Hz to 4 Hz half way: no one clock has these ticks
    times = np.concatenate([np.arange(300) / RATE, 60.0 + np.arange(1, 240) / 4.0])
    times = times + scatter(times.size)
    assert slot_clock(times, RATE) is None
    out = uniform_record(record_of(times, times))
    assert out.reading == ()
    assert np.ptp(np.diff(out.time)) < 1e-9


def test_flat_outputs_keep_the_stamps():
    clock = np.arange(200) / RATE
    rec = Record(time=clock + scatter(clock.size), power=np.zeros(200), load=np.full(200, 0.2),
                 displacement=np.zeros(200), meta={'sample_rate_hz': RATE})
    out = uniform_record(rec)
    assert clock_evidence(rec, slot_clock(rec.time, RATE)) == 0.0
    assert 'samples taken at their stamps' in out.reading[0]


def test_the_cli_warns_which_times_it_took(tmp_path, capsys):
    clock = np.arange(int(SPAN * RATE)) / RATE
    path = tmp_path / 'jittered.csv'
    write_csv_record(record_of(clock, clock + scatter(clock.size)), str(path))
    assert read_record(str(path)).reading
    out = io.StringIO()
    assert main(['simulate', '--compare', str(path), '--out', str(tmp_path)], out=out) == 0
    err = capsys.readouterr().err
    assert f'tca_sim compare: warning: {path}: stamps scatter up to 20 %' in err
    assert 'samples taken on the clock' in err
