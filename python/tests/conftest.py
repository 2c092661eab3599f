"""A plexusd of its own for each test module, on loopback, with its own socket and name server.

The programs come from the environment ctest sets (PLEXUSD, PLEXUS_CLI, PLEXUS_PYTHON_ECHO), else
from build/. Nothing waits for time: the daemon is ready when its --ready-file appears (polled
with a deadline), and it is killed at teardown whatever happened.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import time

import pytest

BUILD = pathlib.Path(__file__).resolve().parents[2] / "build"
PLEXUSD = os.environ.get("PLEXUSD", str(BUILD / "daemon" / "plexusd"))
PLEXUS_CLI = os.environ.get("PLEXUS_CLI", str(BUILD / "tools" / "plexus"))
ECHO = os.environ.get("PLEXUS_PYTHON_ECHO", str(BUILD / "python" / "tests" / "plexus-python-echo"))
READY_DEADLINE = 20.0  # seconds: generous for a loaded machine; the usual start is ~50 ms


def wait_for(condition, deadline: float, what: str, process: subprocess.Popen | None = None):
    """Polls `condition` until it returns something true or the deadline passes."""
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        if process is not None and process.poll() is not None:
            raise RuntimeError(f"{what}: the process exited with {process.returncode}")
        time.sleep(0.005)  # a poll interval, not a wait for something to happen
    raise RuntimeError(f"{what}: not within {deadline} s")


class Daemon:
    """A running plexusd: its socket, names address and an environment for child processes."""

    def __init__(self, directory: pathlib.Path, settings: dict | None = None) -> None:
        self.directory = directory
        self.socket = str(directory / "s.sock")
        ready = directory / "ready"
        config = directory / "plexusd.json"
        # max_frame 64 MiB: the 25 MB image test (the default is 16 MiB).
        config.write_text(json.dumps({"max_frame": 64 << 20, **(settings or {})}))
        self.log = open(directory / "plexusd.log", "w")
        self.process = subprocess.Popen(
            [PLEXUSD, "--embedded-names", "--names", "127.0.0.1:0", "--listen", "127.0.0.1:0",
             "--socket", self.socket, "--ready-file", str(ready), "--config", str(config),
             "--node", "pytest"],
            stdout=self.log, stderr=subprocess.STDOUT)
        try:
            text = wait_for(lambda: ready.exists() and ready.read_text().strip(), READY_DEADLINE,
                            "plexusd ready file", self.process)
            self.ready = json.loads(text)
        except BaseException:
            self.stop()
            raise
        self.names = self.ready["names"]
        self.env = dict(os.environ, PLEXUS_SOCKET=self.socket, PLEXUS_NAMES=self.names,
                        PLEXUS_DISCOVERY="off")

    def cli(self, *args: str, input: str | None = None, timeout: float = 30.0) -> subprocess.CompletedProcess:
        """Runs the plexus CLI against this daemon."""
        return subprocess.run([PLEXUS_CLI, *args], input=input, capture_output=True, text=True,
                              env=self.env, timeout=timeout)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait()
        self.log.close()


@pytest.fixture(scope="module")
def daemon(tmp_path_factory):
    started = Daemon(tmp_path_factory.mktemp("plexusd"))
    try:
        yield started
    finally:
        started.stop()


@pytest.fixture
def client(daemon):
    import plexus

    return plexus.Client(daemon.socket)


@pytest.fixture(scope="module")
def echo(daemon):
    """The C++ echo component (plexus-python-echo), ready when it has opened its ports."""
    process = subprocess.Popen([ECHO], env=daemon.env, stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout.readline().strip() == "ready"
        yield process
    finally:
        process.kill()
        process.wait()
