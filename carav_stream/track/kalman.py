"""Constant-velocity Kalman filter in range and range rate, vectorised over tracks.

State x = (r, rdot) [m, m/s]; the measurement is the range estimator's (range, range rate) of one cycle, so H = I.
Between two cycles dt_s apart the target keeps its velocity, disturbed by an acceleration held over the interval
and drawn afresh each interval with standard deviation sigma_a (the discrete white-noise acceleration model:
Bar-Shalom, Li and Kirubarajan, Estimation with Applications to Tracking and Navigation, 6.3.3):

    x_k+1 = F x_k + G a_k,    F = [[1, dt], [0, 1]],    G = (dt^2 / 2, dt),    a_k ~ N(0, sigma_a^2)
    Q = sigma_a^2 G G^T,      R = diag(sigma_r^2, sigma_v^2)

    predict    x- = F x,   P- = F P F^T + Q
    innovate   nu = z - x-,   S = P- + R
    update     K = P- S^-1,   x = x- + K nu,   P = (I - K) P- (I - K)^T + K R K^T      (Joseph form)
    NIS        eps = nu^T S^-1 nu,   chi-square with 2 degrees of freedom while the model holds

The Joseph form keeps P symmetric and positive definite whatever the rounding, which the short form (I - K) P-
does not promise over a long run of updates.

Arrays are float64: x (..., 2), P (..., 2, 2), z (..., 2); every function broadcasts over the leading axes (the
tracks, or tracks x measurements) and returns new arrays, never changing its inputs. The 2 x 2 inverse is written
out (adjugate over determinant): a cycle of the tracker inverts a few 2 x 2 matrices, for which numpy.linalg's inv
and det spend more on their checks and dispatch than on the arithmetic (measured: the written-out form takes less
time for any number of tracks).
"""
from __future__ import annotations

import numpy as np

_EYE = np.eye(2)


def cv_model(dt_s: float, sigma_accel_mps2: float) -> tuple[np.ndarray, np.ndarray]:
    """(F, Q), float64 (2, 2) each, of the constant-velocity model over dt_s with acceleration RMS sigma_accel_mps2."""
    if not dt_s > 0:
        raise ValueError(f"dt_s: the time between cycles must be > 0 s, got {dt_s!r}")
    if not sigma_accel_mps2 >= 0:
        raise ValueError(f"sigma_accel_mps2: must be >= 0 m/s^2, got {sigma_accel_mps2!r}")
    f = np.array([[1.0, dt_s], [0.0, 1.0]])
    g = np.array([dt_s * dt_s / 2.0, dt_s])
    return f, sigma_accel_mps2 ** 2 * np.outer(g, g)


def measurement_noise(sigma_range_m: float, sigma_velocity_mps: float) -> np.ndarray:
    """R = diag(sigma_r^2, sigma_v^2), float64 (2, 2): the estimator's error covariance of one cycle."""
    for name, value in (("sigma_range_m", sigma_range_m), ("sigma_velocity_mps", sigma_velocity_mps)):
        if not value > 0:
            raise ValueError(f"{name}: the measurement error's standard deviation must be > 0, got {value!r}")
    return np.diag([sigma_range_m ** 2, sigma_velocity_mps ** 2])


def inv2(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(S^-1, det S) of symmetric positive definite 2 x 2 matrices s (..., 2, 2): the adjugate over the determinant."""
    det = s[..., 0, 0] * s[..., 1, 1] - s[..., 0, 1] * s[..., 1, 0]
    out = np.empty_like(s)
    out[..., 0, 0], out[..., 1, 1] = s[..., 1, 1] / det, s[..., 0, 0] / det
    out[..., 0, 1], out[..., 1, 0] = -s[..., 0, 1] / det, -s[..., 1, 0] / det
    return out, det


def predict(x: np.ndarray, p: np.ndarray, f: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One cycle ahead: x- = F x, P- = F P F^T + Q."""
    x_pred = x @ f.T
    p_pred = f @ p @ f.T + q
    return x_pred, 0.5 * (p_pred + np.swapaxes(p_pred, -1, -2))


def innovation(x_pred: np.ndarray, p_pred: np.ndarray, z: np.ndarray,
               r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """nu = z - x-, float64 (..., 2), and its covariance S = P- + R, float64 (..., 2, 2)."""
    return np.asarray(z, dtype=float) - x_pred, p_pred + r


def nis(nu: np.ndarray, s_inv: np.ndarray) -> np.ndarray:
    """Normalised innovation squared nu^T S^-1 nu, float64 (...); s_inv = S^-1 broadcast against nu's axes."""
    return np.einsum("...i,...ij,...j->...", nu, s_inv, nu)


def update(x_pred: np.ndarray, p_pred: np.ndarray, nu: np.ndarray, s: np.ndarray,
           r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The filtered (x, P) after the innovation nu with covariance s (Joseph form, module docstring)."""
    k = p_pred @ inv2(s)[0]
    x = x_pred + np.einsum("...ij,...j->...i", k, nu)
    i_k = _EYE - k
    p = i_k @ p_pred @ np.swapaxes(i_k, -1, -2) + k @ r @ np.swapaxes(k, -1, -2)
    return x, 0.5 * (p + np.swapaxes(p, -1, -2))
