"""The point cloud of a TDM-MIMO radar: every detection of a CFAR list as (range, velocity, azimuth, SNR).

Detections come as the CFAR lists give them (carav_stream/firmware/cfar.py, Detections): per cycle, strongest first,
range_bin (C, K) int64 (-1 after the last), doppler_bin (C, K) int64 and snr_db (C, K) float64. Here the map they
were found on is one over the L = M / S loops (one virtual channel's chirps, or several channels' maps summed):
Doppler bin d is nu = wrap(d / L) / S cycles per chirp (angle.loop_doppler), range bin b the FFT bin b (I/Q) or
b + 1 (I-only). Each cell is refined (angle_refine.refine_cells: beat, Doppler, ML azimuth) and converted:

    range     R = c / (2 S) (f_b - 2 v / lambda)             (Geometry.range_from_beat, coupling removed)
    velocity  v = nu lambda / (2 T_c scale),  |v| < lambda / (4 T_c S)   (Geometry.velocity_from_slow_freq, read at
              the window's centre: the refinement's sums run over every sample)
    azimuth   theta = asin(s), and its bound's standard deviation at the snapshots' measured SNR_eff
              (angle_crlb.azimuth_crlb; another target in the same range bin adds to the loops' scatter, so the
              bound then errs on the large side)

The refinement assumes one target per cell; cells that hold several are angle_music's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from carav_stream.estimate.angle import check_frames, loop_doppler
from carav_stream.estimate.angle_crlb import azimuth_crlb
from carav_stream.estimate.angle_refine import refine_cells
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.virtual_array import VirtualArray

__all__ = ["PointCloud", "point_cloud", "point_cloud_of"]


@dataclass(frozen=True)
class PointCloud:
    """Points per cycle in the detections' order; NaN after n_found.

    range_m, velocity_mps      float64 (C, K)  refined, coupling removed; velocity positive receding
    azimuth_deg                float64 (C, K)  positive towards increasing array position
    azimuth_std_deg            float64 (C, K)  the azimuth's Cramer-Rao standard deviation at the measured SNR
    snr_db                     float64 (C, K)  the detections' SNR, as listed
    n_found                    int64 (C,)
    """

    range_m: np.ndarray
    velocity_mps: np.ndarray
    azimuth_deg: np.ndarray
    azimuth_std_deg: np.ndarray
    snr_db: np.ndarray
    n_found: np.ndarray


def point_cloud(frames, geometry: Geometry, array: VirtualArray, range_bin, doppler_bin, snr_db, rho=None, *,
                n_iter: int = 2) -> PointCloud:
    """The point cloud of the listed detections (module docstring). frames (C, R, M, N) float32 | complex64;
    range_bin, doppler_bin int (C, K), -1 for none; snr_db float (C, K); rho bool (C, M) or None (all active)."""
    x, rho = check_frames(frames, array, rho)
    if x.shape[-1] != geometry.n_samples or np.iscomplexobj(x) != geometry.iq:
        raise ValueError(f"point_cloud: frames have {x.shape[-1]} {'complex' if np.iscomplexobj(x) else 'real'} "
                         f"samples per chirp, geometry says {geometry.n_samples} with iq={geometry.iq}")
    rb, db = np.asarray(range_bin), np.asarray(doppler_bin)
    if rb.shape != db.shape or rb.ndim != 2 or rb.shape[0] != x.shape[0]:
        raise ValueError(f"point_cloud: range_bin {rb.shape} and doppler_bin {db.shape} must be (n_cycles, K) for "
                         f"{x.shape[0]} cycles")
    n_found = (rb >= 0).sum(axis=1).astype(np.int64)
    width = max(int(n_found.max(initial=0)), 1)
    rb, db = rb[:, :width], db[:, :width]
    listed = rb >= 0
    n_samp = geometry.n_samples
    f0 = np.where(listed, (rb + (0 if geometry.iq else 1)) / n_samp, np.nan)
    nu0 = np.where(listed, loop_doppler(db, x.shape[2] // array.n_slots, array.n_slots), np.nan)
    cells = refine_cells(x, array, f0, nu0, rho, n_iter=n_iter)
    f = cells.f - np.floor(cells.f + 0.5) if geometry.iq else cells.f            # I/Q: negative beats above fs / 2
    beat_hz = f * geometry.fs_hz
    velocity = geometry.velocity_from_slow_freq(cells.nu, sample=(n_samp - 1) / 2.0,
                                                delay_s=(cells.f % 1.0) * geometry.fs_hz / geometry.slope_hz_per_s)
    azimuth = np.degrees(np.arcsin(cells.sin_theta))
    std = azimuth_crlb(cells.snr_eff, array.positions_wl, azimuth)["deg"]
    snr = np.where(listed, np.asarray(snr_db, dtype=float)[:, :width], np.nan)
    return PointCloud(geometry.range_from_beat(beat_hz, velocity), velocity, azimuth, std, snr, n_found)


def point_cloud_of(frames, geometry: Geometry, array: VirtualArray, detections, rho=None, **options) -> PointCloud:
    """point_cloud of any object with range_bin, doppler_bin and snr_db (a cfar.Detections), by duck typing."""
    missing = [n for n in ("range_bin", "doppler_bin", "snr_db") if not hasattr(detections, n)]
    if missing:
        raise TypeError(f"point_cloud_of: {type(detections).__name__} lacks {missing}")
    return point_cloud(frames, geometry, array, detections.range_bin, detections.doppler_bin, detections.snr_db, rho,
                       **options)
