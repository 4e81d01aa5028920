"""Sunshine over time (oclshade.sunshine, kernels/sunshine.cl) against the float64 twin
(oclshade.reference.sunshine_sums) and against summing the device's own per-sun masks."""
from __future__ import annotations

from datetime import datetime, timedelta, timezone
from zoneinfo import ZoneInfo

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from oclshade import ShadowCaster, Sun
from oclshade import reference as ref
from oclshade.heightmap import Heightmap
from oclshade.horizon import HorizonCaster
from oclshade.sunshine import MAX_SECONDS, SunshineCaster, daylight, parse_step, time_steps
from oclshade.synthetic import canyon_crater
from test_shadows import azimuths, cell_sizes, elevations, terrains

EPS32 = float(np.finfo(np.float32).eps)


def assert_equals_reference(hm: Heightmap, suns: list[Sun], seconds: list[int]) -> int:
    """Hours and cast fraction equal the reference bit for bit outside ties, and tied
    mismatches are rare; the irradiation within the reference's bound outside ties.
    Returns the number of tied mismatches."""
    got = SunshineCaster(hm).accumulate(suns, np.array(seconds), "all")
    want = ref.sunshine_sums(hm, suns, seconds)
    tied = assert_sums_match(got, want, np.isnan(hm.heights), max(3, hm.heights.size // 10))
    assert got.daylight_seconds == want.daylight_seconds
    return tied


def assert_sums_match(got, want, nodata: np.ndarray, max_tied: int) -> int:
    """The device's hours and cast fraction equal the twin's bit for bit outside ties, at most
    ``max_tied`` tied mismatches; the irradiation (when computed) within the twin's bound
    outside ties.  Returns the number of tied mismatches."""
    tied = 0
    for name, expected in (("hours", want.hours), ("fraction", want.fraction)):
        value = getattr(got, name)
        assert np.array_equal(np.isnan(value), nodata | np.isnan(expected)), name
        differ = (value != expected.astype(np.float32)) & ~np.isnan(value)
        assert not np.any(differ & ~want.ties), f"{name}: {int((differ & ~want.ties).sum())} cells differ"
        tied = max(tied, int(differ.sum()))
    assert tied <= max_tied, f"{tied} tied mismatches is too many"
    if got.irradiation is not None:
        err = np.abs(got.irradiation.astype(np.float64) - want.beam_hours)
        inside = ~want.ties & ~nodata
        assert np.all(err[inside] <= want.beam_bound[inside]), float(np.max((err - want.beam_bound)[inside]))
    return tied


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(h=terrains(), cell=cell_sizes,
       suns=st.lists(st.tuples(azimuths, st.one_of(elevations, st.sampled_from([0.0, -4.0]))), min_size=1, max_size=4),
       seconds=st.integers(1, 3600))
def test_mask_route_equals_reference(h, cell, suns, seconds):
    sun_list = [Sun(az, el) for az, el in suns]
    weights = [seconds + 7 * k for k in range(len(sun_list))]
    assert_equals_reference(Heightmap.from_array(h, cell), sun_list, weights)


def test_a_day_on_generated_terrain_with_holes():
    h = canyon_crater(48, 64, seed=2, relief=900)
    h[20:24, 30:41] = np.nan
    hm = Heightmap.from_array(h, 30.0)
    suns = [Sun(az, el) for az, el in [(70, 3), (95, 20), (140, 45), (180, 60), (220, 40), (265, 15), (290, 2)]]
    assert_equals_reference(hm, suns, [600] * len(suns))


def test_equals_the_sum_of_the_device_masks():
    """What the bench reports: the sums equal the per-sun masks and self flags of ShadowCaster,
    bit for bit (same kernels, same gradient), holes included."""
    h = canyon_crater(60, 50, seed=5, relief=1200)
    h[rng_holes(h.shape, 5)] = np.nan
    hm = Heightmap.from_array(h, (30.0, 25.0))
    suns = [Sun(az, el) for az, el in [(37, 5), (100, 25), (180, 50), (250, 8), (300, -2), (0, 90)]]
    seconds = np.array([600, 600, 300, 600, 600, 1])
    got = SunshineCaster(hm).accumulate(suns, seconds, ("hours", "fraction"))
    caster = ShadowCaster(hm, cache=False)
    sun_s, cast_s, total = np.zeros(hm.shape), np.zeros(hm.shape), 0
    for sun, w in zip(suns, seconds):
        if sun.elevation > 0:
            res = caster.cast(sun, outputs=("mask", "self"))
            sun_s += w * ((res.mask == 0) & (res.self_shadow == 0))
            cast_s += w * (res.mask == 1)
            total += w
    nodata = np.isnan(h)
    assert np.array_equal(got.hours, np.where(nodata, np.nan, sun_s / 3600).astype(np.float32), equal_nan=True)
    assert np.array_equal(got.fraction, np.where(nodata, np.nan, cast_s / total).astype(np.float32), equal_nan=True)
    assert got.daylight_suns == 5 and got.daylight_seconds == total
    assert 0 < np.nanmean(got.fraction) < 1


def rng_holes(shape: tuple[int, int], seed: int) -> np.ndarray:
    return np.random.default_rng(seed).random(shape) < 0.03


def test_flat_map_in_full_sun_everywhere():
    """No relief: every daylight step is direct sun, never cast shadow, cos i = sin(elevation)."""
    hm = Heightmap.from_array(np.full((9, 11), 250.0), 10.0)
    suns = [Sun(90, 30), Sun(180, 60), Sun(0, -10)]
    got = SunshineCaster(hm).accumulate(suns, [3600, 1800, 3600], "all")
    assert np.all(got.hours == np.float32(1.5)) and np.all(got.fraction == 0)
    assert np.allclose(got.irradiation, 0.5 * 1 + np.sin(np.radians(60)) * 0.5, rtol=4 * EPS32)


def test_no_daylight_gives_zero_hours_and_no_fraction():
    hm = Heightmap.from_array(canyon_crater(16, 16, seed=1, relief=100), 30.0)
    got = SunshineCaster(hm).accumulate([Sun(10, -5), Sun(200, 0)], 600, "all")
    assert got.daylight_suns == 0 and got.daylight_seconds == 0
    assert np.all(got.hours == 0) and np.all(np.isnan(got.fraction)) and np.all(got.irradiation == 0)


def test_memory_does_not_grow_with_the_suns(monkeypatch):
    """The same device allocations for 2 suns as for 12: one mask buffer, one set of sums."""
    hm = Heightmap.from_array(canyon_crater(32, 32, seed=3, relief=500), 30.0)
    caster = SunshineCaster(hm)
    caster.shadows.pyramid
    sizes: list[int] = []
    real = caster.runtime.empty
    monkeypatch.setattr(caster.runtime, "empty", lambda nbytes, what: sizes.append(nbytes) or real(nbytes, what))
    counts = []
    for n in (2, 12):
        sizes.clear()
        caster.accumulate([Sun(30.0 * k, 10.0 + k) for k in range(n)], 600, "all")
        counts.append(sorted(sizes))
    assert counts[0] == counts[1]


def test_progress_counts_daylight_suns():
    hm = Heightmap.from_array(canyon_crater(16, 16, seed=1, relief=100), 30.0)
    calls = []
    SunshineCaster(hm).accumulate([Sun(10, -5), Sun(100, 10), Sun(200, 30)], 60, progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 2), (2, 2)]


@pytest.mark.parametrize("suns, seconds, message", [
    ([Sun(10, 10), Sun(20, 20)], [60], "seconds must be one number or one per sun (2), got 1"),
    ([Sun(10, 10)], [0], "seconds must be whole numbers >= 1"),
    ([Sun(10, 10)], [1.5], "seconds must be whole numbers >= 1"),
    ([Sun(10, 10), Sun(20, 20)], [MAX_SECONDS, 1], "at most 4294967295 s"),
])
def test_bad_weights_are_refused(suns, seconds, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        daylight(suns, seconds)


def test_night_does_not_count_towards_the_limit():
    day, weights = daylight([Sun(10, -1), Sun(20, 5)], [MAX_SECONDS, 60])
    assert day == [Sun(20, 5)] and weights.tolist() == [60]


def test_unknown_output_is_refused():
    hm = Heightmap.from_array(np.zeros((4, 4)), 1.0)
    with pytest.raises(ValueError, match="outputs must be a non-empty subset of hours, fraction, irradiation"):
        SunshineCaster(hm).accumulate([Sun(10, 10)], 60, "mask")


# --- the horizon route --------------------------------------------------------------------

def horizon_model(hm: Heightmap, suns: list[Sun], seconds: int, n: int) -> np.ndarray:
    """Hours by the horizon route's definition, in numpy float32 (the kernel's operations):
    direct where the horizon interpolated between the grid azimuths around the sun is not
    above it and the device's self flag is 0."""
    angles = HorizonCaster(hm).horizons(n)
    shadows = ShadowCaster(hm, cache=False)
    total = np.zeros(hm.shape)
    for sun in suns:
        if sun.elevation <= 0:
            continue
        pos = (sun.azimuth % 360.0) * n / 360.0
        i = min(int(np.floor(pos)), n - 1)
        frac = np.float32(pos - i)
        low, high = angles[i], angles[(i + 1) % n]
        cast = low + frac * (high - low) > np.float32(sun.elevation)
        facing = shadows.cast(sun, outputs="self").self_shadow == 0
        total += seconds * (~cast & facing)
    return np.where(np.isnan(hm.heights), np.nan, total / 3600).astype(np.float32)


def test_horizon_route_is_its_definition():
    """Suns in every part of the circle, the wrap from the last grid azimuth to 0 included."""
    h = canyon_crater(40, 36, seed=8, relief=700)
    h[rng_holes(h.shape, 8)] = np.nan
    hm = Heightmap.from_array(h, 30.0)
    suns = [Sun(az, el) for az, el in [(3, 10), (95, 4), (100, 20), (181, 35), (260, 6), (355, 8), (359.9, 12),
                                       (200, -1)]]
    for n in (8, 17):
        got = SunshineCaster(hm).accumulate(suns, 600, method="horizons", azimuths=n)
        assert np.array_equal(got.hours, horizon_model(hm, suns, 600, n), equal_nan=True), n


def test_horizon_route_on_grid_azimuths_equals_the_reference():
    """A sun on a grid azimuth needs no interpolation: exact, as the masks (ties apart)."""
    hm = Heightmap.from_array(canyon_crater(48, 40, seed=9, relief=1000), (30.0, 20.0))
    suns = [Sun(360.0 * k / 16, 2.0 + 3.0 * k) for k in range(16)]
    got = SunshineCaster(hm).accumulate(suns, 600, ("hours", "fraction"), method="horizons", azimuths=16)
    want = ref.sunshine_sums(hm, suns, [600] * len(suns))
    for name, expected in (("hours", want.hours), ("fraction", want.fraction)):
        differ = getattr(got, name) != expected.astype(np.float32)
        assert not np.any(differ & ~want.ties) and differ.sum() <= 3, name


def test_horizon_route_error_shrinks_with_the_azimuths():
    hm = Heightmap.from_array(canyon_crater(64, 64, seed=10, relief=900), 30.0)
    rng = np.random.default_rng(1)
    suns = [Sun(float(a), float(e)) for a, e in zip(rng.uniform(0, 360, 30), rng.uniform(2, 50, 30))]
    caster = SunshineCaster(hm)
    masks = caster.accumulate(suns, 600).hours
    errors = [np.abs(caster.accumulate(suns, 600, method="horizons", azimuths=n).hours - masks).mean()
              for n in (8, 64, 512)]
    assert errors[0] > errors[1] > errors[2] and errors[0] > 0


def test_horizon_route_computes_each_needed_band_once(monkeypatch):
    """Suns in two azimuth intervals of 64 (5.625 degrees): the four bands around them, no more,
    whatever the number of suns (counted as the bands the horizon caster hands out, however many
    azimuths its launches batch)."""
    hm = Heightmap.from_array(canyon_crater(24, 24, seed=3, relief=300), 30.0)
    caster = SunshineCaster(hm)
    computed: list[float] = []
    real = HorizonCaster.angles_on_device

    def counting(self, azimuths):
        for azimuth, buf in real(self, azimuths):
            computed.append(azimuth)
            yield azimuth, buf

    monkeypatch.setattr(HorizonCaster, "angles_on_device", counting)
    suns = [Sun(90.0 + 0.5 * k, 10.0) for k in range(5)] + [Sun(270.0 + 0.5 * k, 10.0) for k in range(5)]
    caster.accumulate(suns, 600, method="horizons", azimuths=64)
    assert sorted(computed) == [90.0, 95.625, 270.0, 275.625]


def test_unknown_method_and_bad_azimuths_are_refused():
    caster = SunshineCaster(Heightmap.from_array(np.zeros((4, 4)), 1.0))
    with pytest.raises(ValueError, match="method must be one of masks, horizons; got 'rays'"):
        caster.accumulate([Sun(10, 10)], 60, method="rays")
    with pytest.raises(ValueError, match="the number of azimuths must be an integer"):
        caster.accumulate([Sun(10, 10)], 60, method="horizons", azimuths=0)


# --- time steps ---------------------------------------------------------------------------

UTC = timezone.utc


def test_steps_sample_midpoints_and_weigh_their_length():
    steps = time_steps(datetime(2024, 6, 1, tzinfo=UTC), datetime(2024, 6, 1, 0, 25, tzinfo=UTC), timedelta(minutes=10))
    assert steps.seconds.tolist() == [600, 600, 300]
    assert steps.times == [datetime(2024, 6, 1, 0, 5, tzinfo=UTC), datetime(2024, 6, 1, 0, 15, tzinfo=UTC),
                           datetime(2024, 6, 1, 0, 22, 30, tzinfo=UTC)]


def test_steps_across_a_daylight_saving_change_count_elapsed_time():
    """2024-03-31 in Zurich has 23 hours: 23 hourly steps, not 24."""
    zone = ZoneInfo("Europe/Zurich")
    steps = time_steps(datetime(2024, 3, 31, tzinfo=zone), datetime(2024, 4, 1, tzinfo=zone), timedelta(hours=1))
    assert len(steps.times) == 23 and steps.seconds.sum() == 23 * 3600
    assert steps.times[2] == datetime(2024, 3, 31, 1, 30, tzinfo=UTC)   # 03:30 local summer time


@pytest.mark.parametrize("start, end, step, message", [
    (datetime(2024, 6, 2, tzinfo=UTC), datetime(2024, 6, 1, tzinfo=UTC), timedelta(hours=1), "end must be after start"),
    (datetime(2024, 6, 1), datetime(2024, 6, 2, tzinfo=UTC), timedelta(hours=1), "start must be a timezone-aware"),
    (datetime(2024, 6, 1, tzinfo=UTC), datetime(2024, 6, 2, tzinfo=UTC), timedelta(0), "step must be a positive"),
    (datetime(2024, 6, 1, tzinfo=UTC), datetime(2024, 6, 2, tzinfo=UTC), timedelta(seconds=0.5), "whole number"),
    (datetime(2024, 6, 1, tzinfo=UTC), datetime(2024, 6, 1, 0, 0, 1, 500, tzinfo=UTC), timedelta(seconds=1),
     "end - start must be a whole number of seconds"),
])
def test_bad_periods_are_refused(start, end, step, message):
    with pytest.raises(ValueError, match=message):
        time_steps(start, end, step)


@pytest.mark.parametrize("text, seconds", [("10min", 600), ("30s", 30), ("1h", 3600), (" 2 H ", 7200),
                                           ("1d", 86400), ("45sec", 45)])
def test_parse_step(text, seconds):
    assert parse_step(text) == timedelta(seconds=seconds)


@pytest.mark.parametrize("text", ["10", "10m", "0min", "-5min", "1.5h", "min", "10 minutes"])
def test_parse_step_refuses(text):
    with pytest.raises(ValueError, match="step must be a positive whole number with a unit s, min, h or d"):
        parse_step(text)
