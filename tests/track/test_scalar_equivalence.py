"""The plain-float cycle (track/scalar.py, taken for a few tracks) against the array formulation (kalman.py and
association.py over all tracks, taken for many): on random streams with several targets, crossings, clutter, missed
detections, refused cycles, births and deletions, the two give the same tracks, ids, statuses and alarms, and states,
covariances and NIS equal within 1e-9 relative."""
from unittest import mock

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from carav_stream.track import TrackerConfig, Tracks, scalar, step
from carav_stream.track import tracker as tracker_module

DT = 0.05


def _stream(seed: int, n_targets: int, n_cycles: int, clutter: float, p_refused: float,
            p_detect: float) -> list[list[tuple[float, float]] | None]:
    """Targets a few metres apart at a few m/s (their gates meet and they cross), moving as the model says;
    each cycle refused (None) or measured: each target detected with p_detect, Poisson clutter around them, in a
    random order."""
    rng = np.random.default_rng(seed)
    x = np.stack([rng.uniform(20.0, 23.0, n_targets), rng.uniform(-3.0, 3.0, n_targets)], axis=1)
    out = []
    for _ in range(n_cycles):
        x = x + [[DT, 0.0]] * x[:, 1:] + np.outer(rng.normal(0.0, 1.5, n_targets), [DT * DT / 2, DT])
        if rng.random() < p_refused:
            out.append(None)
            continue
        z = [tuple(t + rng.normal(0.0, 1.0, 2) * [0.1, 0.05]) for t in x if rng.random() < p_detect]
        z += [(rng.uniform(18.0, 26.0), rng.uniform(-4.0, 4.0)) for _ in range(rng.poisson(clutter))]
        out.append([z[i] for i in rng.permutation(len(z))])
    return out


def _assert_same(stream: list, config: TrackerConfig) -> None:
    few, many = Tracks.empty(config), Tracks.empty(config)
    for k, z in enumerate(stream):
        few, a = step(few, z, config)
        with mock.patch.object(tracker_module, "SCALAR_MAX_PAIRS", -1):      # every cycle by arrays
            many, b = step(many, z, config)
        where = f"cycle {k}"
        assert (a.lists["id"], a.status, a.born, a.deleted) == (b.lists["id"], b.status, b.born, b.deleted), where
        assert (a.lists["updated"], a.lists["nis_alarm"], a.measured) == (b.lists["updated"], b.lists["nis_alarm"],
                                                                         b.measured), where
        for name in ("range_m", "velocity_mps", "var_range_m2", "var_velocity_m2ps2", "nis"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=0, err_msg=where)
        np.testing.assert_allclose(few.p, many.p, rtol=1e-9, atol=0, err_msg=where)
        for name in ("confirmed", "hits", "measured", "misses", "idle"):
            np.testing.assert_array_equal(getattr(few, name), getattr(many, name), err_msg=where)
        np.testing.assert_allclose(few.nis, many.nis, rtol=1e-9, atol=0, err_msg=where)
        assert few.next_id == many.next_id


def _config(**kw) -> TrackerConfig:
    return TrackerConfig(dt_s=DT, sigma_accel_mps2=1.5, sigma_range_m=0.1, sigma_velocity_mps=0.05, **kw)


@settings(max_examples=25)
@given(seed=st.integers(0, 2 ** 32 - 1), n_targets=st.integers(1, 4), clutter=st.sampled_from([0.0, 0.3, 2.0]),
       p_refused=st.sampled_from([0.0, 0.2, 0.6]), p_detect=st.sampled_from([1.0, 0.8]),
       confirm=st.sampled_from([(1, 1), (2, 3), (3, 5)]), delete_misses=st.integers(1, 4),
       coast_cycles=st.sampled_from([0, 3, 64]), nis=st.sampled_from([(0.0, 1), (0.05, 1), (0.05, 4)]))
def test_the_plain_float_cycle_tracks_as_the_array_formulation(seed, n_targets, clutter, p_refused, p_detect, confirm,
                                                                delete_misses, coast_cycles, nis):
    config = _config(confirm_m=confirm[0], confirm_n=confirm[1], delete_misses=delete_misses,
                     coast_cycles=coast_cycles, nis_pfa=nis[0], nis_window=nis[1])
    _assert_same(_stream(seed, n_targets, 120, clutter, p_refused, p_detect), config)


def test_both_associations_of_the_plain_float_cycle_agree_with_the_assignment():
    """Over streams where gates meet, the plain-float cycle pairs some cycles itself (no conflict) and asks the
    assignment for others (a measurement in two gates, two in one): both kinds occur, and both give the array
    formulation's tracks."""
    calls, cycles = [], 0
    gnn = scalar.gnn

    def counted(*args):
        calls.append(1)
        return gnn(*args)
    with mock.patch.object(scalar, "gnn", counted):
        for seed in range(4):
            stream = _stream(seed, 3, 150, 1.0, 0.1, 0.9)
            cycles += sum(z is not None for z in stream)
            _assert_same(stream, _config(nis_pfa=0.01, nis_window=2))
    assert 0 < len(calls) < cycles / 2
