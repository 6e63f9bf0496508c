"""Every figure the project draws: a title, labelled axes, a legend where several series are drawn, reference lines
labelled, and tick labels that do not overlap (checked on the drawn matplotlib figures, not on pixels)."""
from __future__ import annotations

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402

from bench import main as run_bench  # noqa: E402
from carav_stream.cli import main as carav  # noqa: E402


@pytest.fixture
def drawn(monkeypatch):
    """The figures the code saves, kept in memory instead of written."""
    figures: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: figures.append(self))
    return figures


def _is_reference(line) -> bool:
    x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
    return x.size == 2 and (x[0] == x[1] or y[0] == y[1])


def check(fig: Figure) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for ax in fig.axes:
        where = ax.get_title() or "an untitled panel"
        assert ax.get_title(), "a panel without a title"
        assert ax.get_xlabel() and ax.get_ylabel(), f"{where}: an axis without a label"
        lines = ax.get_lines()
        for line in lines:
            if _is_reference(line):
                assert not line.get_label().startswith("_"), f"{where}: a reference line without a label"
        series = [line for line in lines if not line.get_label().startswith("_")]
        if len(series) > 1:
            assert ax.get_legend() is not None, f"{where}: {len(series)} series and no legend"
        for axis, lo in ((ax.xaxis, 0), (ax.yaxis, 1)):
            boxes = sorted((t.get_window_extent(renderer) for t in axis.get_ticklabels(which="both")
                            if t.get_visible() and t.get_text()), key=lambda b: (b.x0, b.y0)[lo])
            for a, b in zip(boxes, boxes[1:]):
                gap = (b.x0 - a.x1) if lo == 0 else (b.y0 - a.y1)
                assert gap > -0.5, f"{where}: overlapping tick labels on its {'xy'[lo]} axis"


def test_the_threshold_sweep_figure(drawn, tmp_path):
    assert carav(["sweep", "--preset", "table1", "--attack", "random,smart", "--rarms", "1,3", "--trials", "40",
                  "--eta", "0.5:3:0.1", "--seed", "1", "--quiet", "--plot", str(tmp_path / "s.png")]) == 0
    assert len(drawn) == 1
    check(drawn[0])


@pytest.mark.slow
def test_the_error_against_time_figure(drawn, tmp_path):
    assert run_bench(["estimators", "--quick", "--presets", "table1", "--estimators", "fft_peak,fft_interp,ml",
                  "--plot", str(tmp_path / "e.png")]) == 0
    assert len(drawn) == 1
    check(drawn[0])


def test_the_secondary_antenna_figure(drawn):
    from carav_stream.experiments.secondary_antenna import plot
    rng = np.random.default_rng(0)
    results = [{"attacker": "secondary_antenna", "power": p, "rarms": r, "q": rng.gamma(4, 0.4, 200),
                "range_error_m": rng.exponential(0.5, 200)} for p, r in (("low", 0.5), ("high", 3.0))]
    plot(results, rng.gamma(3, 0.3, 500), 1.5, "unused.png")
    check(drawn[0])


def test_the_ghost_spectrum_figure(drawn, tmp_path):
    from carav_stream.experiments.beyond_paper import _plot_ghost
    from carav_stream.radar.scene_loader import load_scene
    _plot_ghost(load_scene("table1"), tmp_path, np.random.default_rng(1))
    check(drawn[0])


def test_the_checker_refuses_a_bare_figure():
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="a")
    ax.plot([0, 1], [1, 0], label="b")
    ax.axhline(0.5)
    with pytest.raises(AssertionError, match="without a title"):
        check(fig)
    ax.set(title="t", xlabel="x [m]", ylabel="y [m]")
    with pytest.raises(AssertionError, match="reference line without a label"):
        check(fig)
    plt.close(fig)


def test_the_checker_sees_overlapping_tick_labels():
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(3, 3))
    ax.loglog([0.31, 0.52], [0.31, 0.52], "o", label="a")   # a narrow log span: minor labels crowd the axis
    ax.set(title="t", xlabel="x [ms]", ylabel="y [m]")
    with pytest.raises(AssertionError, match="overlapping tick labels"):
        check(fig)
    plt.close(fig)


def test_the_ghost_misses_figure(drawn, tmp_path):
    from carav_stream.experiments.beyond_paper import _plot_ghost_pm
    rows = [{"rarms": r, "trials": 100, "alarms": a, "spectral_detections": s, "integrated_detections": i,
             "coherent_detections": c, "reported_by_radar": rep}
            for r, a, s, i, c, rep in ((0.01, 0, 0, 0, 0, 0), (0.05, 0, 2, 40, 60, 30), (0.2, 0, 90, 100, 100, 100),
                                       (1.0, 3, 100, 100, 100, 100))]
    _plot_ghost_pm(rows, tmp_path)
    check(drawn[0])
    assert "RARMS 0.2" in " ".join(line.get_label() for line in drawn[0].axes[0].get_lines())
