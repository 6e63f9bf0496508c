"""`carav experiment matlab-table1`: the ESTIMATION.md comparison with MATLAB's published FMCWExample result."""
import numpy as np
import pytest

from carav_stream.cli import main as carav
from carav_stream.estimate.matlab_reference import MATLAB_TABLE1_CLOSING_SPEED_MPS, MATLAB_TABLE1_RANGE_M
from carav_stream.experiments.matlab_table1 import figures, simulate


@pytest.fixture(scope="module")
def fig():
    return figures(simulate(30, 5))


def test_the_published_values_sit_inside_the_replica_spread_and_the_accepted_interval_is_three_sigma(fig):
    for name, published in (("range", MATLAB_TABLE1_RANGE_M), ("closing_speed", MATLAB_TABLE1_CLOSING_SPEED_MPS)):
        t = fig["matlab"][name]
        lo, hi = t["accepted"]
        assert lo < published < hi and abs(t["z"]) < 3
        assert hi - lo == pytest.approx(6 * fig["stats"]["replica_" + ("range_m" if name == "range" else
                                                                        "closing_speed_mps")]["std"])
    # the velocity test is weak: it would have accepted a published closing speed of the wrong sign
    assert fig["matlab"]["closing_speed"]["accepted"][0] < 0
    # ml is far tighter than the replica, and unbiased in range once the coupling is removed (mid-frame truth)
    st = fig["stats"]
    assert st["ml_velocity_mps"]["std"] < st["replica_closing_speed_mps"]["std"] / 50
    assert st["ml_range_m"]["mean"] == pytest.approx(43.0, abs=4 * st["ml_range_m"]["std"])


def test_the_command_prints_the_table_and_is_deterministic(capsys):
    assert carav(["experiment", "matlab-table1", "--cycles", "10", "--seed", "3"]) == 0
    first = capsys.readouterr().out
    assert "| our replica of the MATLAB chain | closing speed [m/s] |" in first and "accepts any published" in first
    assert carav(["experiment", "matlab-table1", "--cycles", "10", "--seed", "3"]) == 0
    assert capsys.readouterr().out == first
    assert np.isfinite(figures(simulate(10, 3))["matlab"]["range"]["z"])
