#!/usr/bin/env python3
"""The Python client against the C++ client and pyzmq, in the same run.

Jobs: 64 B ping-pong latency (p50/p99 of round trip / 2; Python writer -> Python echo process ->
back) and 1 MiB NumPy throughput (one writer process streams uint8 arrays, the reader counts
them). The C++ figures are plexus-bench's loopback scenarios (same sizes, strict queue); pyzmq
does the same two jobs over ipc:// (PAIR for the ping-pong, PUSH/PULL for the stream, arrays sent
with copy=False and read with numpy.frombuffer). Every run starts its own plexusd.

    PYTHONPATH=build/python /usr/bin/python3 python/bench/python_bench.py [--runs 3]

Needs build/ (plexusd, plexus-bench, the module) and python3-zmq (scripts/bench-peers-setup).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = ROOT / "build"
PING_COUNT = 20000
STREAM_COUNT = 3000
MIB = 1 << 20

CHILD = r"""
import sys, time, numpy
role, endpoint = sys.argv[1], sys.argv[2]
if role == "plexus-echo":
    import plexus
    client = plexus.Client(endpoint)
    inp, out = client.open("/bench/ping"), client.open("/bench/pong")
    print("ready", flush=True)
    for message in inp:
        out.write(message.data)
elif role == "plexus-stream":
    import plexus
    client = plexus.Client(endpoint)
    out = client.open("/bench/stream/out")
    sys.stdin.readline()  # go
    array = numpy.random.default_rng(1).integers(0, 256, 1 << 20, dtype=numpy.uint8)
    for i in range(int(sys.argv[3])):
        out.write(array)
    out.close()
elif role == "zmq-echo":
    import zmq
    socket = zmq.Context().socket(zmq.PAIR)
    socket.connect(endpoint)
    print("ready", flush=True)
    while True:
        socket.send(socket.recv(copy=False), copy=False)
elif role == "zmq-stream":
    import zmq
    context = zmq.Context()  # held: the I/O thread sends from the array after send() returns
    socket = context.socket(zmq.PUSH)
    socket.setsockopt(zmq.SNDHWM, 64)
    socket.connect(endpoint)
    sys.stdin.readline()
    array = numpy.random.default_rng(1).integers(0, 256, 1 << 20, dtype=numpy.uint8)
    for i in range(int(sys.argv[3])):
        socket.send(array, copy=False)
    socket.close(linger=-1)
    context.term()
"""


def child(role: str, endpoint: str, *extra: str, env=None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", CHILD, role, endpoint, *extra], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)


def percentiles(samples: list[float]) -> tuple[float, float]:
    samples.sort()
    return samples[len(samples) // 2], samples[int(len(samples) * 0.99)]


class Daemon:
    def __init__(self, directory: str) -> None:
        self.socket = os.path.join(directory, "s.sock")
        ready = pathlib.Path(directory, "ready")
        self.process = subprocess.Popen(
            [str(BUILD / "daemon/plexusd"), "--embedded-names", "--names", "127.0.0.1:0", "--listen",
             "127.0.0.1:0", "--socket", self.socket, "--ready-file", str(ready), "--log-level", "warn"])
        end = time.monotonic() + 20
        while not (ready.exists() and ready.read_text().strip()):
            if time.monotonic() > end or self.process.poll() is not None:
                raise RuntimeError("plexusd did not start")
            time.sleep(0.005)

    def stop(self) -> None:
        self.process.kill()
        self.process.wait()


def plexus_latency(socket: str) -> tuple[float, float]:
    import plexus

    client = plexus.Client(socket)
    ping, pong = client.open("/bench/ping/out"), client.open("/bench/pong/in")
    echo = child("plexus-echo", socket, env=dict(os.environ, PLEXUS_SOCKET=socket))
    try:
        assert echo.stdout.readline().strip() == "ready"
        client.connect("/bench/ping/out", "/bench/ping")
        client.connect("/bench/pong", "/bench/pong/in")
        payload = b"x" * 64
        samples = []
        for i in range(PING_COUNT + 1000):
            start = time.perf_counter_ns()
            ping.write(payload)
            pong.read()
            if i >= 1000:  # warm-up first
                samples.append((time.perf_counter_ns() - start) / 2000)
        return percentiles(samples)
    finally:
        echo.kill()
        echo.wait()


def plexus_throughput(socket: str) -> float:
    import plexus

    client = plexus.Client(socket)
    inp = client.open("/bench/stream/in")
    writer = child("plexus-stream", socket, str(STREAM_COUNT))
    try:
        while not client.exists("/bench/stream/out"):
            time.sleep(0.005)
        client.connect("/bench/stream/out", "/bench/stream/in")
        writer.stdin.write("go\n")
        writer.stdin.flush()
        first = inp.read(timeout=30)
        start = time.perf_counter()
        for _ in range(STREAM_COUNT - 1):
            message = inp.read(timeout=30)
            assert message.data.nbytes == MIB
        return (STREAM_COUNT - 1) / (time.perf_counter() - start)
    finally:
        writer.kill()
        writer.wait()


def zmq_latency(directory: str) -> tuple[float, float]:
    import zmq

    endpoint = f"ipc://{directory}/pair"
    socket = zmq.Context.instance().socket(zmq.PAIR)
    socket.bind(endpoint)
    echo = child("zmq-echo", endpoint)
    try:
        assert echo.stdout.readline().strip() == "ready"
        payload = b"x" * 64
        samples = []
        for i in range(PING_COUNT + 1000):
            start = time.perf_counter_ns()
            socket.send(payload)
            socket.recv()
            if i >= 1000:
                samples.append((time.perf_counter_ns() - start) / 2000)
        return percentiles(samples)
    finally:
        echo.kill()
        echo.wait()
        socket.close(linger=0)


def zmq_throughput(directory: str) -> float:
    import zmq

    endpoint = f"ipc://{directory}/stream"
    socket = zmq.Context.instance().socket(zmq.PULL)
    socket.bind(endpoint)
    writer = child("zmq-stream", endpoint, str(STREAM_COUNT))
    try:
        writer.stdin.write("go\n")
        writer.stdin.flush()
        socket.recv(copy=False)
        start = time.perf_counter()
        for _ in range(STREAM_COUNT - 1):
            frame = socket.recv(copy=False)
            assert numpy.frombuffer(frame.buffer, dtype=numpy.uint8).nbytes == MIB
        return (STREAM_COUNT - 1) / (time.perf_counter() - start)
    finally:
        writer.kill()
        writer.wait()
        socket.close(linger=0)


def cpp(scenario: str, size: int) -> dict:
    out = subprocess.run([str(BUILD / "tools/plexus-bench"), scenario, "--size", str(size), "--repeat", "1",
                          "--json"], capture_output=True, text=True, check=True).stdout
    return next(r for r in map(json.loads, out.splitlines()) if r["system"] == "plexus")


def one_run() -> dict:
    load = os.getloadavg()[0]  # the machine is shared: how busy it was when this run began
    with tempfile.TemporaryDirectory() as directory:
        daemon = Daemon(directory)
        try:
            py_p50, py_p99 = plexus_latency(daemon.socket)
            py_rate = plexus_throughput(daemon.socket)
        finally:
            daemon.stop()
        zmq_p50, zmq_p99 = zmq_latency(directory)
        zmq_rate = zmq_throughput(directory)
    latency = cpp("latency", 64)
    throughput = cpp("throughput", MIB)
    return {"load_1min": load, "python_p50_us": py_p50, "python_p99_us": py_p99, "python_1mib_msgs_per_s": py_rate,
            "cpp_p50_us": latency["p50_us"], "cpp_p99_us": latency["p99_us"],
            "cpp_1mib_msgs_per_s": throughput["msgs_per_s"],
            "pyzmq_p50_us": zmq_p50, "pyzmq_p99_us": zmq_p99, "pyzmq_1mib_msgs_per_s": zmq_rate}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    runs = [one_run() for _ in range(parser.parse_args().runs)]
    for run in runs:
        print(json.dumps({k: round(v, 1) for k, v in run.items()}))
    median = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    print("medians:", json.dumps({k: round(v, 1) for k, v in median.items()}))
    print(f"64 B one-way p50: Python {median['python_p50_us']:.1f} us, C++ {median['cpp_p50_us']:.1f} us "
          f"({median['python_p50_us'] / median['cpp_p50_us']:.2f}x), pyzmq {median['pyzmq_p50_us']:.1f} us")
    print(f"1 MiB NumPy: Python {median['python_1mib_msgs_per_s']:.0f} msgs/s, C++ "
          f"{median['cpp_1mib_msgs_per_s']:.0f} ({median['python_1mib_msgs_per_s'] / median['cpp_1mib_msgs_per_s']:.0%}),"
          f" pyzmq {median['pyzmq_1mib_msgs_per_s']:.0f}")


if __name__ == "__main__":
    main()
