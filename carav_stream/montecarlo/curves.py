"""PF and PM curves against the threshold, drawn as the paper's Figures 3 to 5 (matplotlib, imported only when a
figure is drawn: it is an optional dependency)."""
from __future__ import annotations

import numpy as np

from carav_stream.detect.detector import PAPER_ETA

__all__ = ["plot_curves", "reference_eta"]


def reference_eta(detector: str) -> float:
    """The threshold a table reports at: the paper's (PAPER_ETA) for C(eta), the PF = 1e-6 design (1) for opt-in
    ones."""
    return PAPER_ETA if detector == "carav" else 1.0


def plot_curves(result: dict, path: str, title: str | None = None) -> None:
    """PF and PM against eta per RARMS, one panel per attack, with the line of the paper's eta (its Figs 3-5)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = list(dict.fromkeys((c.get("detector", "carav"), c["attack"]) for c in result["curves"]))
    fig, axes = plt.subplots(1, len(panels), figsize=(6.4 * len(panels), 4.4), squeeze=False)
    for ax, (detector, attack) in zip(axes[0], panels):
        curves = [c for c in result["curves"] if (c.get("detector", "carav"), c["attack"]) == (detector, attack)]
        ref = reference_eta(detector)
        eta = np.asarray(curves[0]["eta"])
        ax.plot(eta, curves[0]["pf"], color="k", lw=2, label="$P_F$ (no attack)")
        colors = plt.cm.viridis(np.linspace(0, 0.9, len(curves)))
        for c, col in zip(curves, colors):
            ax.plot(eta, c["pm"], color=col, lw=1.5, label=f"$P_M$ RARMS={c['rarms']:g}")
            lo, hi = np.asarray(c["pm_ci"]).T
            ax.fill_between(eta, lo, hi, color=col, alpha=0.15, lw=0)
        ax.axvline(ref, color="r", ls="--", lw=1,
                   label=rf"$\eta$ = {PAPER_ETA:g}" if detector == "carav" else "PF = 1e-6 design")
        ax.set_xlabel(r"threshold $\eta$" if detector == "carav" else f"{detector} threshold / its PF = 1e-6 value")
        ax.set_ylabel("probability")
        ax.set_ylim(-0.02, 1.02)
        label = "" if detector == "carav" else f" ({detector} test)"
        ax.set_title(f"{title or result['scene']['name']}{label}: {attack} attack, {curves[0]['trials']} cycles/curve")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
