"""One target's ML azimuth (angle_refine) at its Cramer-Rao bound (angle_crlb, checked in test_angle_crlb.py) at the
awr1642 scene's SNR on its 2TX x 4RX layout, I/Q and I-only, from closed-form frames: RMSE over 300 cycles within
0.8 and 1.2 times the bound."""
import numpy as np
import pytest

from carav_stream.estimate.angle_crlb import azimuth_crlb, effective_snr
from carav_stream.estimate.angle_refine import refine_cells
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.virtual_array import VirtualArray
from carav_stream.radar.scene_loader import load_scene
from tests.estimate import mimo_tones as mt

AWR1642 = VirtualArray(mt.AWR1642["rx"], mt.AWR1642["tx"], mt.AWR1642["schedule"])


def _rmse_over_bound(iq, azimuth_deg, n_cycles=300, chunk=50):
    scene = load_scene("awr1642")
    g = Geometry.from_scene(scene)
    snr_db = scene.snr_db(0)
    f = scene.beat_hz(scene.targets[0]) / g.fs_hz
    nu = float(g.slow_freq_from_velocity(scene.range_rate_mps(scene.targets[0])))
    nu -= np.floor(2 * nu + 0.5) / 2                     # the per-chirp progression modulo the TDM ambiguity
    rng = np.random.default_rng(int(10 * azimuth_deg) + iq)
    err = []
    for _ in range(n_cycles // chunk):
        x = mt.frames(rng, chunk, [mt.Tone(f, nu, azimuth_deg)], snr_db=snr_db, iq=iq)
        cells = refine_cells(x, AWR1642, np.full((chunk, 1), np.round(f * 256) / 256),
                             np.full((chunk, 1), np.round(nu * 128) / 128))
        err.append(np.degrees(np.arcsin(cells.sin_theta[:, 0])) - azimuth_deg)
    err = np.concatenate(err)
    bound = azimuth_crlb(effective_snr(snr_db, 256, 64, iq=iq), AWR1642.positions_wl, azimuth_deg)["deg"]
    return np.sqrt(np.mean(err ** 2)) / bound


@pytest.mark.slow
@pytest.mark.parametrize("iq", [True, False])
@pytest.mark.parametrize("azimuth_deg", [0.0, 20.0, 45.0])
def test_one_targets_ml_azimuth_reaches_its_bound_at_the_awr1642_snr(iq, azimuth_deg):
    assert 0.8 < _rmse_over_bound(iq, azimuth_deg) < 1.2
