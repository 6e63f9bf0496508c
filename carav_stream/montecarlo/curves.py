"""PF and PM curves against the threshold, and the detector's ROC, drawn with matplotlib (imported only when a
figure is drawn: it is an optional dependency).

Two layouts. `scale="log"` (what `carav sweep --plot` and `carav study --plot` draw) is the threshold designer's:
PF and PM on a logarithmic axis reaching below the design PF, so that the 1e-3 to 1e-6 tail where thresholds are
chosen is visible, and under each panel the ROC (probability of detection 1 - PM against PF, one curve per RARMS,
a point per threshold of the grid). A Monte Carlo estimate of 0 has no place on a log axis: it is drawn at its
95 % upper bound with a downward marker ("fewer than this"), never as a point on the floor. `scale="linear"` draws
PF and PM on a linear axis as the paper's Figures 3 to 5 do, for comparing with them.
"""
from __future__ import annotations

import numpy as np

from carav_stream.detect.detector import PAPER_ETA

__all__ = ["draw_curves", "plot_curves", "reference_eta"]


def reference_eta(detector: str) -> float:
    """The threshold a table reports at: the paper's (PAPER_ETA) for C(eta), the PF = 1e-6 design (1) for opt-in
    ones."""
    return PAPER_ETA if detector == "carav" else 1.0


def _floor(result: dict, curves: list[dict]) -> float:
    """The lowest probability the log axis shows: a decade under the smaller of the design PF and the resolution
    of the Monte Carlo (the 95 % upper bound of 0 events in the curve's trials)."""
    design_pf = (result.get("design") or {}).get("cfar_target_pf", 1.0)
    bounds = [np.min(np.asarray(c[key])[:, 1]) for c in curves for key in ("pf_ci", "pm_ci")]
    return 10.0 ** np.floor(np.log10(min(design_pf, *bounds)) - 1.0)


def _log_curve(ax, eta, p, ci, color, label, lw):
    """p against eta on a log axis: the estimate where it is above 0, its 95 % band, and the upper bound with a
    downward marker where no event was seen."""
    p, ci = np.asarray(p, float), np.asarray(ci, float)
    seen = p > 0
    ax.plot(eta, np.where(seen, p, np.nan), color=color, lw=lw, label=label)
    ax.fill_between(eta, np.maximum(ci[:, 0], 1e-300), ci[:, 1], where=seen, color=color, alpha=0.15, lw=0)
    if not seen.all():
        ax.plot(eta[~seen], ci[~seen, 1], ls="none", marker="v", ms=3, color=color, alpha=0.6)


def _pf_pm_panel(ax, result, curves, detector, attack, scale, title, colors):
    ref = reference_eta(detector)
    eta = np.asarray(curves[0]["eta"], float)
    trials = curves[0]["trials"]
    if scale == "log":
        _log_curve(ax, eta, curves[0]["pf"], curves[0]["pf_ci"], "k", "$P_F$ (no attack)", 2)
        for c, col in zip(curves, colors):
            _log_curve(ax, eta, c["pm"], c["pm_ci"], col, f"$P_M$ RARMS={c['rarms']:g}", 1.5)
        ax.set_yscale("log")
        ax.set_ylim(_floor(result, curves), 1.5)
        design_pf = (result.get("design") or {}).get("cfar_target_pf")
        if design_pf:
            ax.axhline(design_pf, color="grey", ls=":", lw=1, label=f"design $P_F$ = {design_pf:g}")
    else:
        ax.plot(eta, curves[0]["pf"], color="k", lw=2, label="$P_F$ (no attack)")
        for c, col in zip(curves, colors):
            ax.plot(eta, c["pm"], color=col, lw=1.5, label=f"$P_M$ RARMS={c['rarms']:g}")
            lo, hi = np.asarray(c["pm_ci"]).T
            ax.fill_between(eta, lo, hi, color=col, alpha=0.15, lw=0)
        ax.set_ylim(-0.02, 1.02)
    ax.axvline(ref, color="r", ls="--", lw=1,
               label=rf"$\eta$ = {PAPER_ETA:g}" if detector == "carav" else "PF = 1e-6 design")
    ax.set_xlabel(r"threshold $\eta$" if detector == "carav" else f"{detector} threshold / its PF = 1e-6 value")
    ax.set_ylabel("probability")
    label = "" if detector == "carav" else f" ({detector} test)"
    ax.set_title(f"{title or result['scene']['name']}{label}: {attack} attack, {trials} cycles/curve", fontsize=10)
    ax.grid(alpha=0.3, which="both" if scale == "log" else "major")


def _roc_panel(ax, result, curves, colors):
    """1 - PM against PF over the threshold grid, PF on a log axis; a PF of 0 at its 95 % upper bound (open)."""
    pf, pf_hi = np.asarray(curves[0]["pf"], float), np.asarray(curves[0]["pf_ci"], float)[:, 1]
    x = np.where(pf > 0, pf, pf_hi)
    for c, col in zip(curves, colors):
        pd = 1.0 - np.asarray(c["pm"], float)
        ax.plot(x[pf > 0], pd[pf > 0], color=col, lw=1.5, marker=".", ms=3, label=f"RARMS={c['rarms']:g}")
        ax.plot(x[pf == 0], pd[pf == 0], ls="none", marker="o", mfc="none", ms=4, color=col, alpha=0.6)
    design_pf = (result.get("design") or {}).get("cfar_target_pf")
    if design_pf:
        ax.axvline(design_pf, color="grey", ls=":", lw=1, label=f"design $P_F$ = {design_pf:g}")
    ax.set_xscale("log")
    ax.set_xlim(_floor(result, curves), 1.5)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("$P_F$ (open markers: no false alarm seen, drawn at the 95 % upper bound)")
    ax.set_ylabel("$P_D = 1 - P_M$")
    ax.set_title("ROC over the threshold grid", fontsize=10)
    ax.grid(alpha=0.3, which="both")


def draw_curves(result: dict, title: str | None = None, scale: str = "log"):
    """The matplotlib Figure of the sweep `result`: per (detector, attack) panel PF and PM against eta, and with
    scale="log" the ROC beneath it (module docstring)."""
    if scale not in ("log", "linear"):
        raise ValueError(f"scale: expected 'log' or 'linear', got {scale!r}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = list(dict.fromkeys((c.get("detector", "carav"), c["attack"]) for c in result["curves"]))
    rows = 2 if scale == "log" else 1
    fig, axes = plt.subplots(rows, len(panels), figsize=(6.4 * len(panels), 4.4 * rows), squeeze=False)
    for i, (detector, attack) in enumerate(panels):
        curves = [c for c in result["curves"] if (c.get("detector", "carav"), c["attack"]) == (detector, attack)]
        colors = plt.cm.viridis(np.linspace(0, 0.9, len(curves)))
        _pf_pm_panel(axes[0, i], result, curves, detector, attack, scale, title, colors)
        if scale == "log":
            _roc_panel(axes[1, i], result, curves, colors)
    for ax in axes.flat:              # legends below the axes: nothing covers a curve
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3, frameon=False)
    fig.tight_layout()
    return fig


def plot_curves(result: dict, path: str, title: str | None = None, scale: str = "log") -> None:
    """Draw the sweep `result` into the image file `path` (draw_curves)."""
    import matplotlib.pyplot as plt

    fig = draw_curves(result, title, scale)
    fig.savefig(path, dpi=110)
    plt.close(fig)
