"""MUSIC over the virtual array (angle_music): two targets at the same range and velocity, 15 degrees apart on the
8-element virtual ULA of the awr1642 layout, resolved from their cell's single snapshot by forward-backward spatial
smoothing; without smoothing the coherent pair's covariance has rank one and MUSIC does not resolve them."""
import numpy as np
import pytest

from carav_stream.estimate.angle import sin_grid
from carav_stream.estimate.angle_music import music_azimuths, music_spectrum, smoothed_covariance, uniform_snapshots
from carav_stream.estimate.angle_refine import refine_cells
from carav_stream.estimate.virtual_array import VirtualArray
from carav_stream.radar.scene_loader import load_scene
from tests.estimate import mimo_tones as mt

AWR1642 = VirtualArray(mt.AWR1642["rx"], mt.AWR1642["tx"], mt.AWR1642["schedule"])
PAIR = (5.0, 20.0)


def _pair_snapshots(iq, n_cycles=40, seed=71):
    """The cells' snapshots (C, 1, 8) of two equal targets at PAIR degrees, same beat and Doppler (random phases)."""
    f, nu = 41.3 / 256, 0.0371
    x = mt.frames(np.random.default_rng(seed + iq), n_cycles, [mt.Tone(f, nu, PAIR[0]), mt.Tone(f, nu, PAIR[1])],
                  snr_db=load_scene("awr1642").snr_db(0), iq=iq)
    cells = refine_cells(x, AWR1642, np.full((n_cycles, 1), 41 / 256), np.full((n_cycles, 1), 5 / 128))
    return cells.snapshots


@pytest.mark.parametrize("iq", [True, False])
def test_music_resolves_two_targets_in_one_cell_fifteen_degrees_apart(iq):
    z = _pair_snapshots(iq)
    az = music_azimuths(z, AWR1642, 2)
    assert az.shape == (40, 2)
    assert np.abs(az - np.array(PAIR)).max() < 0.1
    spectrum = music_spectrum(z, AWR1642, 2, n_angle=512)
    grid = np.degrees(np.arcsin(sin_grid(512)))
    peaks = (spectrum[:, 1:-1] > spectrum[:, :-2]) & (spectrum[:, 1:-1] > spectrum[:, 2:])
    for c in range(40):
        top = grid[1:-1][peaks[c]][np.argsort(spectrum[c, 1:-1][peaks[c]])[-2:]]
        assert np.sort(top) == pytest.approx(PAIR, abs=0.5)


def test_without_smoothing_the_coherent_pair_has_rank_one_and_is_not_resolved():
    z = _pair_snapshots(True)
    y, _ = uniform_snapshots(z, AWR1642)
    eig = np.linalg.eigvalsh(smoothed_covariance(y, 8, forward_backward=False))
    assert np.all(eig[:, -2] < 1e-5 * eig[:, -1])                            # one source's worth
    eig_fb = np.linalg.eigvalsh(smoothed_covariance(y, 7))
    assert np.all(eig_fb[:, -2] > 1e-3 * eig_fb[:, -1])                      # two
    bad = music_azimuths(z, AWR1642, 2, length=8, forward_backward=False)
    assert np.mean(np.abs(bad - np.array(PAIR)).max(axis=1) > 1.0) > 0.9


def test_duplicate_positions_are_averaged_and_a_non_uniform_array_is_refused_by_its_positions():
    overlap = VirtualArray((0.0, 0.5, 1.0, 1.5), (0.0, 1.0), (0, 1))            # 0 .. 2.5 wl, 1.0 and 1.5 twice
    z = np.exp(2j * np.pi * overlap.positions_wl * np.sin(np.radians(-30.0)))[None, None, :]
    y, d = uniform_snapshots(z, overlap)
    assert d == pytest.approx(0.5) and y.shape == (1, 1, 6)
    assert np.allclose(y[0, 0], np.exp(2j * np.pi * 0.5 * np.arange(6) * np.sin(np.radians(-30.0))))
    assert music_azimuths(z, overlap, 1)[0, 0] == pytest.approx(-30.0, abs=1e-6)
    with pytest.raises(ValueError, match=r"positions \[0.0, 0.5, 1.7\]"):
        music_azimuths(np.ones((1, 1, 3)), VirtualArray((0.0, 0.5, 1.7)), 1)
    with pytest.raises(ValueError, match="subarray length"):
        music_azimuths(z, overlap, 2, length=2)
