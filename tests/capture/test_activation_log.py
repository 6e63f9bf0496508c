"""The private activation log: written for its owner alone, read back exactly, bad lines named."""
import stat

import numpy as np
import pytest

from carav_stream.capture.activation_log import ActivationLogError, read_log, write_log


def test_the_log_reads_back_exactly_and_only_its_owner_may_read_it(tmp_path):
    rho = np.random.default_rng(3).random((5, 16)) < 0.5
    path = tmp_path / "r.activation"
    path.write_text("old")
    path.chmod(0o644)                                     # an existing, readable file becomes private too
    write_log(path, [3, 4, 7, 8, 9], rho)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    cycles, back = read_log(path, 16)
    assert cycles.tolist() == [3, 4, 7, 8, 9]
    np.testing.assert_array_equal(back, rho)


@pytest.mark.parametrize("line, what", [("0 0101", "expected '<cycle> <8 digits"), ("x 01010101", "expected"),
                                        ("0 01010102", "expected"), ("0 01010101 extra", "expected")])
def test_a_bad_line_is_named_by_file_and_line_number(tmp_path, line, what):
    path = tmp_path / "bad.activation"
    path.write_text(f"# comment\n1 01010101\n{line}\n")
    path.chmod(0o600)
    with pytest.raises(ActivationLogError, match=rf"bad.activation:3: {what}"):
        read_log(path, 8)


def test_a_missing_log_says_where_it_was_looked_for(tmp_path):
    with pytest.raises(ActivationLogError, match="nope.activation: activation log not found"):
        read_log(tmp_path / "nope.activation", 8)


@pytest.mark.parametrize("mode", [0o640, 0o604, 0o700 | 0o010])
def test_a_log_its_group_or_others_may_reach_is_refused_naming_its_mode(tmp_path, mode):
    path = tmp_path / "shared.activation"
    write_log(path, [0], np.zeros((1, 8), dtype=bool))
    path.chmod(mode)
    with pytest.raises(ActivationLogError, match=rf"shared.activation: activation log has mode {mode:04o}: its group "
                                                 "or others have access to it"):
        read_log(path, 8)
