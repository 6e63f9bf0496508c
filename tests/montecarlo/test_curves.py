"""The threshold designer's figure: PF and PM on a log axis reaching below the design PF, a ROC beneath, zero
estimates drawn at their 95 % upper bound, legends outside the axes; the paper's linear layout on request."""
import numpy as np
import pytest

from carav_stream.montecarlo.curves import draw_curves

pytest.importorskip("matplotlib")      # an optional dependency (the plot extra)


def result(design_pf=1e-4):
    eta = np.linspace(0.5, 3.0, 26)
    trials = 1000
    pf = np.clip(np.exp(-8 * (eta - 0.5)), 0, 1).round(3)            # reaches 0 events (no false alarm) at the top
    pm = np.clip(1 - np.exp(-3 * (eta - 1.0)), 0, 1).round(3)

    def ci(p):
        return [[max(0.0, x - 0.01), 3.0 / trials if x == 0 else min(1.0, x + 0.01)] for x in p]
    curves = [{"detector": "carav", "attack": "random", "rarms": r, "trials": trials, "eta": eta.tolist(),
               "pf": pf.tolist(), "pm": pm.tolist(), "pf_ci": ci(pf), "pm_ci": ci(pm)} for r in (1.0, 2.0)]
    return {"scene": {"name": "toy"}, "curves": curves, "design": {"cfar_target_pf": design_pf}}


def test_pf_and_pm_sit_on_a_log_axis_below_the_design_pf_with_a_roc_beneath():
    fig = draw_curves(result(1e-4))
    (top,), (roc,) = fig.axes[0:1], fig.axes[1:2]
    assert top.get_yscale() == "log" and top.get_ylim()[0] < 1e-4 < top.get_ylim()[1]
    assert roc.get_xscale() == "log" and roc.get_xlim()[0] < 1e-4 and "P_D" in roc.get_ylabel()
    # a PF of 0 events is not drawn on the floor: its upper bound (3 / trials) carries a downward marker
    markers = [line for line in top.get_lines() if line.get_marker() == "v"]
    assert markers and all(np.allclose(m.get_ydata(), 3e-3) for m in markers)
    for ax in fig.axes:                # every legend sits below its axes: none covers a curve
        box = ax.get_legend().get_window_extent(fig.canvas.get_renderer())
        assert box.y1 <= ax.get_window_extent(fig.canvas.get_renderer()).y0


def test_the_linear_layout_draws_one_row_like_the_papers_figures():
    fig = draw_curves(result(), scale="linear")
    assert len(fig.axes) == 1 and fig.axes[0].get_yscale() == "linear"
    with pytest.raises(ValueError, match="scale: expected 'log' or 'linear', got 'dB'"):
        draw_curves(result(), scale="dB")
