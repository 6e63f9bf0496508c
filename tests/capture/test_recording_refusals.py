"""A recording a replay cannot trust is refused before anything runs, in one line naming the file and the field:
metadata fields of the wrong type, samples without a hash to check them by, an activation log others can read."""
import json
import re

import pytest

from carav_stream.capture.sigmf_io import RecordingError, open_recording
from carav_stream.cli import main as carav
from carav_stream.console.errors import Exit
from tests.capture.test_recording_blocks import record


def edited(tmp_path, edit):
    record(tmp_path / "rec")
    meta_path = tmp_path / "rec.sigmf-meta"
    meta = json.loads(meta_path.read_text())
    edit(meta["global"])
    meta_path.write_text(json.dumps(meta))
    return tmp_path / "rec"


WRONG_TYPES = [
    ("carav:graph", "a graph", r"global carav:graph: expected table, got 'a graph'"),
    ("carav:graph", {"nodes": ["detector"]}, r"global carav:graph: nodes: expected a table of tables"),
    ("carav:graph", {"nodes": {"detector": 3}}, r"global carav:graph: nodes: expected a table of tables"),
    ("carav:scene", 7, r"global carav:scene: expected str, got 7"),
    ("carav:scene_file", ["a.toml"], r"global carav:scene_file: expected str, got \['a.toml'\]"),
    ("carav:batch", "16", r"global carav:batch: expected int, got '16'"),
]


@pytest.mark.parametrize("key, value, message", WRONG_TYPES)
def test_a_metadata_field_of_the_wrong_type_is_named(tmp_path, key, value, message):
    base = edited(tmp_path, lambda g: g.update({key: value}))
    with pytest.raises(RecordingError, match=rf"rec.sigmf-meta: {message}"):
        open_recording(base)


@pytest.mark.parametrize("key, value, message", WRONG_TYPES[:2])
def test_replay_refuses_a_metadata_field_of_the_wrong_type_in_one_line_exit_3(tmp_path, capsys, key, value, message):
    base = edited(tmp_path, lambda g: g.update({key: value}))
    assert carav(["replay", str(base), "--no-progress"]) == Exit.INVALID
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert re.search(message, err), err


def test_replay_refuses_a_recording_whose_hash_was_removed_unless_told_not_to_check(tmp_path, capsys):
    base = edited(tmp_path, lambda g: g.pop("core:sha512"))
    with pytest.raises(RecordingError, match="rec.sigmf-meta: global core:sha512: missing"):
        open_recording(base)
    assert carav(["replay", str(base), "--no-progress"]) == Exit.INVALID
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "rec.sigmf-meta: global core:sha512: missing" in err, err
    assert open_recording(base, verify_hash=False).samples.shape[0] == 6      # a reader that does not check: asked


def test_replay_refuses_an_activation_log_others_can_read_in_one_line(tmp_path, capsys):
    record(tmp_path / "rec")
    (tmp_path / "rec.activation").chmod(0o644)
    assert carav(["replay", str(tmp_path / "rec"), "--no-progress"]) == Exit.INVALID
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert "rec.activation: activation log has mode 0644: its group or others have access to it" in err, err


@pytest.mark.parametrize("top, message", [
    ({"global": []}, "global: expected a table, got list"),
    ({"annotations": {}}, "annotations: expected a list, got dict"),
    ({"captures": "x"}, "captures: expected a list, got str"),
])
def test_replay_refuses_metadata_of_the_wrong_shape_in_one_line(tmp_path, capsys, top, message):
    record(tmp_path / "rec")
    meta_path = tmp_path / "rec.sigmf-meta"
    meta = json.loads(meta_path.read_text())
    key, value = next(iter(top.items()))
    meta[key] = [meta[key]] if key == "global" else value
    meta_path.write_text(json.dumps(meta))
    assert carav(["replay", str(tmp_path / "rec"), "--no-progress"]) == Exit.INVALID
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert f"rec.sigmf-meta: not valid SigMF: {message}" in err, err


def test_a_recording_of_no_cycle_opens_empty(tmp_path):
    from carav_blocks.sigmf_sink import SigmfSink
    from tests.capture.test_recording_blocks import IQ_SCENE

    sink = SigmfSink(path=str(tmp_path / "rec"), scene=IQ_SCENE, batch=2)
    sink.start()
    sink.finish()                               # the recorder received no frame at all
    rec = open_recording(tmp_path / "rec")
    assert rec.samples.shape == (0, 4, 256, 2) and rec.rho.shape == (0, 4)


def test_a_recording_refuses_its_log_turned_into_one_without_checksum(tmp_path, capsys):
    record(tmp_path / "rec")
    log = tmp_path / "rec.activation"
    lines = log.read_text().splitlines()
    lines[0] = lines[0].replace("log v2", "log v1")     # a log "downgraded" by hand: header edited, checksum cut
    log.write_text("\n".join(lines[:-1]) + "\n")
    log.chmod(0o600)
    assert carav(["replay", str(tmp_path / "rec"), "--no-progress"]) == Exit.INVALID
    err = capsys.readouterr().err
    assert "rec.activation: activation log is not the checksummed log its recording was written with" in err, err
