#!/usr/bin/env python3
"""Where a 1 MiB NumPy stream's time goes: CPU and page faults per message of each Python process.

The same stream as python_bench.py's (a writer process writes uint8 arrays of 1 MiB, this process
reads them, strict queue, its own plexusd), reporting besides msgs/s the reader's and the writer's
CPU time (user + system) and minor page faults per message, from getrusage around the loop. On a
shared machine the rate swings with the load; the CPU per message much less, which is what tells
whether a change made a side cheaper.

    PYTHONPATH=build/python /usr/bin/python3 python/bench/stream_cpu.py [--runs 3] [--count 3000]
"""

from __future__ import annotations

import argparse
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import python_bench  # noqa: E402  (its Daemon)

WRITER = r"""
import resource, sys, numpy, plexus
client = plexus.Client(sys.argv[1])
out = client.open("/bench/stream/out")
sys.stdin.readline()  # go
array = numpy.random.default_rng(1).integers(0, 256, 1 << 20, dtype=numpy.uint8)
before = resource.getrusage(resource.RUSAGE_SELF)
for _ in range(int(sys.argv[2])):
    out.write(array)
out.close()
after = resource.getrusage(resource.RUSAGE_SELF)
cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
print(cpu, after.ru_minflt - before.ru_minflt, flush=True)
"""


def cpu_and_faults(before, after) -> tuple[float, int]:
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, after.ru_minflt - before.ru_minflt


def one_run(socket: str, count: int) -> dict:
    import plexus

    client = plexus.Client(socket)
    inp = client.open("/bench/stream/in")
    writer = subprocess.Popen([sys.executable, "-c", WRITER, socket, str(count)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 20
        while not client.exists("/bench/stream/out"):
            if time.monotonic() > deadline or writer.poll() is not None:
                raise RuntimeError("the writer did not open its port")
            time.sleep(0.005)
        client.connect("/bench/stream/out", "/bench/stream/in")
        writer.stdin.write("go\n")
        writer.stdin.flush()
        inp.read(timeout=30)  # the first message: the stream has started
        before = resource.getrusage(resource.RUSAGE_SELF)
        start = time.perf_counter()
        for _ in range(count - 1):
            message = inp.read(timeout=30)
            assert message is not None and message.data.nbytes == 1 << 20
        seconds = time.perf_counter() - start
        reader_cpu, reader_faults = cpu_and_faults(before, resource.getrusage(resource.RUSAGE_SELF))
        writer_cpu, writer_faults = writer.stdout.readline().split()
        writer.wait(timeout=30)
    finally:
        writer.kill()
        writer.wait()
    return {"msgs_per_s": (count - 1) / seconds,
            "reader_cpu_us_per_msg": 1e6 * reader_cpu / (count - 1),
            "reader_faults_per_msg": reader_faults / (count - 1),
            "writer_cpu_us_per_msg": 1e6 * float(writer_cpu) / count,
            "writer_faults_per_msg": int(writer_faults) / count}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--count", type=int, default=3000)
    arguments = parser.parse_args()
    for _ in range(arguments.runs):
        with tempfile.TemporaryDirectory() as directory:
            daemon = python_bench.Daemon(directory)
            try:
                result = one_run(daemon.socket, arguments.count)
            finally:
                daemon.stop()
        print(" ".join(f"{k} {v:.1f}" for k, v in result.items()), flush=True)


if __name__ == "__main__":
    main()
