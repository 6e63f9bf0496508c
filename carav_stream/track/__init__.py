"""Tracking in range and range rate: what the car makes of the radar's cycles over time.

    kalman.py       the constant-velocity Kalman filter (predict, innovation, NIS, Joseph-form update)
    association.py  the chi-square gate and global nearest neighbour association (scipy's linear_sum_assignment)
    scalar.py       the same filter and association for a cycle of a few tracks, written out in Python floats
    tracker.py      a cycle of the multi-target tracker: track birth, M-of-N confirmation, deletion after misses or
                    a coast limit, the opt-in NIS alarm; a refused cycle is no measurement, never no target
    figures.py      a run's tracks scored against the truth: confirmed, false and dragged tracks, each target's
                    held, coasted and lost cycles, the first alarms after an attack's start

A kernel floor like radar/, detect/ and estimate/: pure functions (on numpy arrays, or on Python floats for a few
tracks), importing only numpy and scipy.
"""
from carav_stream.track.association import gate_threshold, gnn
from carav_stream.track.figures import NEAR_M, NEAR_MPS, TrackFigures
from carav_stream.track.kalman import cv_model, measurement_noise
from carav_stream.track.tracker import PLAIN_KEYS, STATUSES, CycleReport, TrackerConfig, Tracks, run, steady, step

__all__ = ["NEAR_M", "NEAR_MPS", "PLAIN_KEYS", "STATUSES", "CycleReport", "TrackFigures", "TrackerConfig", "Tracks",
           "cv_model", "gate_threshold", "gnn", "measurement_noise", "run", "steady", "step"]
