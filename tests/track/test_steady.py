"""tracker.steady, the tracker's path through a radar's usual cycles (one confirmed track, one measurement within its
gate), against `step`: over random streams with a second target, clutter, outliers, missed detections and refused
cycles, it takes exactly the cycles it should and gives, to the bit, the tracks and values `step` gives; and the
tracker block, which takes that path whenever it can, writes the same frames and summary as when it cannot."""
import json
import random
from unittest import mock

import numpy as np
import pytest

import carav_blocks.tracker as tracker_block
from carav_blocks.tracker import Tracker
from carav_stream.runtime import Frame
from carav_stream.track import TrackerConfig, Tracks, steady, step

DT = 2.5e-4


def _config(**kw) -> TrackerConfig:
    return TrackerConfig(**{"dt_s": DT, "sigma_accel_mps2": 8.0, "sigma_range_m": 0.0025,
                            "sigma_velocity_mps": 0.01, **kw})


def _stream(seed: int, n: int, speed: float = 1.5) -> list:
    """Measured cycles (lists of pairs) and refused ones (None): a car at 43 m (at `speed`), sometimes a second at
    20 m, clutter, outliers far out of the gate, missed detections; for odd seeds an attack refused from cycle 200
    on, for 30 cycles or for 60."""
    rng = random.Random(seed)
    cars = [(43.0, speed)] + ([(20.0, -2.0)] if seed % 3 == 0 else [])
    out = []
    for k in range(n):
        if rng.random() < 0.1:
            out.append(None)
            continue
        z = [(r + v * k * DT + rng.gauss(0.0, 0.0025 * rng.choice([1, 1, 1, 1, 50])), v + rng.gauss(0.0, 0.01))
             for r, v in cars if rng.random() < 0.95]
        if rng.random() < 0.05:
            z.append((rng.uniform(5.0, 80.0), rng.uniform(-5.0, 5.0)))
        out.append(z)
    if seed % 2:
        outage = 30 if seed % 4 == 1 else 60
        out[200:200 + outage] = [None] * outage
    return out


def _usual(tracks: Tracks, z, config: TrackerConfig) -> bool:
    """Whether the cycle is one `steady` must take (step's own verdict): nothing born or deleted, and either one
    confirmed track updated by the cycle's one measurement or coasting through an unmeasured cycle, or no track and
    no measurement."""
    if not len(tracks):
        return z is None
    if len(tracks) != 1 or not tracks.rows[0][2] or z is not None and len(z) != 1:
        return False
    after, report = step(tracks, z, config)
    return len(after) == 1 and not report.born and not report.deleted and bool(report.updated.all()) == (z is not None)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("nis", [(0.0, 1), (1e-3, 4)])
def test_steady_takes_exactly_the_usual_cycles_and_gives_steps_numbers_to_the_bit(seed, nis):
    config = _config(nis_pfa=nis[0], nis_window=nis[1], confirm_m=2, confirm_n=3, coast_cycles=8)
    stream = _stream(seed, 400)
    ref, mixed, k, taken = Tracks.empty(config), Tracks.empty(config), 0, [0, 0, 0]
    while k < len(stream):
        # what step makes of the cycles steady should take, one by one
        expected = []
        probe = ref
        while k + len(expected) < len(stream) and _usual(probe, stream[k + len(expected)], config):
            probe, report = step(probe, stream[k + len(expected)], config)
            if not len(probe):
                expected.append((None, None, None))
                continue
            alarm = None if report.nis_alarm is None else bool(report.nis_alarm[0])
            nis = None if report.lists["nis"][0] != report.lists["nis"][0] else report.lists["nis"][0]
            expected.append((probe.rows[0][1], nis, alarm))
        mixed, done = steady(mixed, iter(stream[k:]), config)
        assert repr(done) == repr(expected), k
        if done:
            ref, k = probe, k + len(done)
            taken[0] += sum(x is not None and nis is not None for x, nis, _ in done)     # updated
            taken[1] += sum(x is not None and nis is None for x, nis, _ in done)         # coasting
            taken[2] += sum(x is None for x, _, _ in done)                               # no track
        else:                                   # the cycle is step's: both take it
            ref, _ = step(ref, stream[k], config)
            mixed, _ = step(mixed, stream[k], config)
            k += 1
        assert repr(mixed.rows) == repr(ref.rows) and mixed.next_id == ref.next_id, k
    if seed % 3:                                   # one car: updated and coasting cycles met
        assert 0.2 * len(stream) < taken[0] < len(stream) and taken[1] > 10
    else:                                          # two cars: two tracks, never a cycle with one
        assert taken[:2] == [0, 0]
    if seed % 2:                                   # the attack outlasts the coast limit: cycles without a track
        assert taken[2] >= 10


def test_steady_leaves_a_tentative_track_two_tracks_two_measurements_and_an_outlier_to_step():
    config = _config()
    tracks = Tracks.empty(config)
    tracks, _ = step(tracks, [(43.0, 0.0)], config)               # born: tentative
    assert steady(tracks, iter([[(43.0, 0.0)]]), config) == (tracks, [])
    for _ in range(3):
        tracks, _ = step(tracks, [(43.0, 0.0)], config)
    assert tracks.confirmed.all() and len(tracks) == 1
    for cycles in ([[(43.0, 0.0), (43.001, 0.0)]], [[(50.0, 0.0)]], [[]]):
        assert steady(tracks, iter(cycles), config) == (tracks, []), cycles
    after, done = steady(tracks, iter([[(43.0, 0.0)], [(43.0, 0.0)], [(50.0, 0.0)], [(43.0, 0.0)]]), config)
    assert len(done) == 2 and after.rows[0][3] == tracks.rows[0][3] + 2      # stops at the outlier
    two, _ = step(tracks, [(43.0, 0.0), (20.0, 0.0)], config)
    assert len(two) == 2 and steady(two, iter([[(43.0, 0.0)]]), config) == (two, [])


def _frames(seed: int) -> list:
    """The estimator's and the gate's frames of a random run, in arrival order: the car on table1_following's target
    (43 m, at rest), so that the run's figures score a track on it."""
    rng = np.random.default_rng(seed)
    stream, batch, out = _stream(seed, 700, speed=0.0), int(rng.choice([4, 8, 32])), []
    for seq, c0 in enumerate(range(0, len(stream), batch)):
        cycles = range(c0, min(c0 + batch, len(stream)))
        clean = [c for c in cycles if stream[c] is not None]
        refused = [c for c in cycles if stream[c] is None]
        if clean:
            out.append(("estimates", Frame({"seq": seq, "cycle": c0, "cycles": len(clean), "per_cycle": {
                "cycle_index": clean, "attack_active": [c >= 350 for c in clean],
                "range_m": [[r for r, _ in stream[c]] for c in clean],
                "velocity_mps": [[v for _, v in stream[c]] for c in clean]}})))
        if refused:
            out.append(("alarms", Frame({"seq": seq, "cycle": c0, "cycles": len(refused), "alarm": True, "per_cycle": {
                "cycle_index": refused, "reason": ["attack"] * len(refused),
                "attack_active": [c >= 350 for c in refused]}})))
    return out


def _run_block(seed: int) -> list[str]:
    block = Tracker(scene="table1_following", sigma_range_m=0.0025, sigma_velocity_mps=0.01, coast_cycles=40,
                    nis_pfa=1e-3 if seed % 2 else 0.0, nis_window=8)
    block.start()
    out = []
    for port, frame in _frames(seed):
        sent = block.process(*((frame, None) if port == "estimates" else (None, frame)))
        out += [json.dumps(sent.header)] if sent is not None else []
    end = block.finish()
    return out + ([json.dumps(end.header)] if end is not None else []) + [json.dumps(block.summary())]


@pytest.mark.parametrize("seed", range(6))
def test_the_tracker_block_writes_the_same_frames_and_summary_with_and_without_the_steady_path(seed):
    fast = _run_block(seed)
    with mock.patch.object(tracker_block, "steady", lambda tracks, cycles, config: (tracks, [])):
        every_cycle_by_step = _run_block(seed)
    assert fast == every_cycle_by_step
    assert sum(f.count('"confirmed"') for f in fast) > 300        # the steady path had cycles to take
    target, = json.loads(fast[-1])["run"]["tracks"]["targets"]    # and the figures scored a track on the car
    assert target["held_cycles"] > 300 and target["coasted_cycles"] > 20
