"""Blocking reads: timeouts, and a reader that is killed while a stream flows."""

import subprocess
import sys
import textwrap
import time

import plexus
from conftest import wait_for


def test_read_times_out_with_none(client):
    inp = client.open("/read/quiet")
    start = time.monotonic()
    assert inp.read(timeout=0.3) is None
    took = time.monotonic() - start
    assert 0.28 <= took < 2.0
    assert inp.read(timeout=0) is None  # only what is there


def test_a_message_ends_a_long_wait_at_once(client):
    out = client.open("/read/soon/out")
    inp = client.open("/read/soon/in")
    client.connect("/read/soon/out", "/read/soon/in")
    out.write("now")
    start = time.monotonic()
    assert inp.read(timeout=30).data == "now"
    assert time.monotonic() - start < 1.0


READER = textwrap.dedent("""
    import sys, plexus
    client = plexus.Client(sys.argv[1])
    port = client.open("/read/victim")
    print("ready", flush=True)
    for message in port:
        print(message.data, flush=True)
""")


def test_a_reader_killed_mid_stream_leaves_the_writer_and_the_daemon_working(daemon, client):
    out = client.open("/read/stream/out")
    reader = subprocess.Popen([sys.executable, "-c", READER, daemon.socket], stdout=subprocess.PIPE,
                              text=True, env=daemon.env)
    try:
        assert reader.stdout.readline().strip() == "ready"
        client.connect("/read/stream/out", "/read/victim")
        for i in range(100):
            out.write({"i": i, "pad": b"x" * 1000})
        assert reader.stdout.readline().strip()  # it is receiving
        reader.kill()
        reader.wait()
        # The writer goes on (the dead reader's port is gone; nothing blocks or raises) ...
        wait_for(lambda: not client.exists("/read/victim"), 20, "the killed reader's port to go")
        for i in range(100, 2000):
            out.write({"i": i, "pad": b"x" * 1000})
        # ... and a new reader gets what is written next.
        second = client.open("/read/second")
        client.connect("/read/stream/out", "/read/second")
        out.write({"i": "after"})
        assert second.read(timeout=10).data == {"i": "after"}
        assert client.stats()["daemon"]["sessions"] >= 1
    finally:
        reader.kill()
        reader.wait()


def test_closing_a_port_ends_its_iteration(client):
    inp = client.open("/read/closing")
    inp.close()
    assert list(inp) == []
    assert not inp.is_open
