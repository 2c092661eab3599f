"""plexus.Recording: a recording made by `plexus record`, read back from Python."""

import signal
import subprocess

import numpy
import pytest

import plexus
from conftest import PLEXUS_CLI, wait_for


def test_a_recording_reads_back_every_message_with_its_payload(client, daemon, tmp_path):
    out = client.open("/rec/out")
    inp = client.open("/rec/in")
    client.connect("/rec/out", "/rec/in")
    path = tmp_path / "rec.mcap"
    recorder = subprocess.Popen([PLEXUS_CLI, "record", "/rec/in", "-o", str(path)], env=daemon.env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(path.exists, 10.0, "the recording's file", recorder)
        sent = [{"n": n, "text": "x" * n} for n in range(20)] + [numpy.arange(12, dtype=numpy.int32)]
        for value in sent:
            out.write(value)
        for _ in sent:
            assert inp.read(timeout=10) is not None
    finally:
        recorder.send_signal(signal.SIGINT)
        assert recorder.wait(30) == 0, recorder.stderr.read()

    recording = plexus.Recording(str(path))
    assert recording.ports == ["/rec/in"]
    assert recording.message_count == len(sent)
    assert [c["source"] for c in recording.connections] == ["/rec/out"]
    assert recording.end_note["lost_messages"] == "0"
    messages = recording.messages()
    assert [m.source for m in messages] == ["/rec/out"] * len(sent)
    assert [m.data for m in messages[:20]] == sent[:20]
    assert numpy.array_equal(messages[20].data, sent[20])
    assert all(m.arrived_ns >= m.sent_ns > 0 for m in messages)
    assert len(recording.messages(limit=3)) == 3
    assert recording.messages(ports=["/not/recorded"]) == []


def test_a_file_that_is_not_a_recording_raises_an_error_naming_the_offset(tmp_path):
    path = tmp_path / "bad.mcap"
    path.write_bytes(b"\x89MCAP0\r\n" + b"\0" * 64)
    with pytest.raises(plexus.RefusedError, match="offset"):
        plexus.Recording(str(path))
