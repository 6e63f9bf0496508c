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


def _written(tmp_path, rows=4):
    path = tmp_path / "r.activation"
    write_log(path, list(range(rows)), np.random.default_rng(5).random((rows, 8)) < 0.5)
    return path


@pytest.mark.parametrize("edit", [
    lambda t: t.replace(t.splitlines()[2], t.splitlines()[2][:-1] + "10"[int(t.splitlines()[2][-1])]),
    lambda t: t.replace(t.splitlines()[3] + "\n", ""),                    # a row removed
    lambda t: t.replace(t.splitlines()[2], t.splitlines()[2] + "\n9 " + t.splitlines()[2].split()[1]),  # one added
    lambda t: t.replace(t.splitlines()[2], "7 " + t.splitlines()[2].split()[1]),   # a cycle renumbered
], ids=["bit flipped", "row removed", "row added", "cycle renumbered"])
def test_a_tampered_row_is_refused_naming_the_file(tmp_path, edit):
    path = _written(tmp_path)
    path.write_text(edit(path.read_text()))
    path.chmod(0o600)
    with pytest.raises(ActivationLogError, match=r"r.activation: activation log does not match its checksum"):
        read_log(path, 8)


def test_a_log_cut_before_its_checksum_line_is_refused(tmp_path):
    path = _written(tmp_path)
    path.write_text("".join(path.read_text().splitlines(keepends=True)[:-2]))
    path.chmod(0o600)
    with pytest.raises(ActivationLogError, match=r"r.activation: activation log has no checksum line"):
        read_log(path, 8)


def test_the_checksum_line_is_the_sha256_of_everything_before_it(tmp_path):
    import hashlib
    text = _written(tmp_path).read_text()
    body, last = text[:text.rindex("# sha256 ")], text.splitlines()[-1]
    assert last == f"# sha256 {hashlib.sha256(body.encode()).hexdigest()}"
