"""An array or bytes written alone leave from their own memory (Port.write_blob underneath) and a
read array views the buffer it was received into, which goes back to libplexus when the array
dies. Each test runs twice: with shared memory between the clients of the daemon, and with a
daemon that has none (shm_total_bytes 0), where large payloads go through the socket.

What must hold on both paths: dtype, shape and values kept, strided arrays included; the writer's
memory is not used after write() returns; a read array stays valid across later reads, whichever
buffers are recycled meanwhile."""

import itertools
import threading

import numpy
import pytest

import plexus
from conftest import Daemon

MIB = 1 << 20
_names = itertools.count()


@pytest.fixture(scope="module", params=["shm", "socket"])
def path_daemon(request, tmp_path_factory):
    settings = {} if request.param == "shm" else {"shm_total_bytes": 0}
    started = Daemon(tmp_path_factory.mktemp(f"plexusd-{request.param}"), settings)
    started.path = request.param
    try:
        yield started
    finally:
        started.stop()


@pytest.fixture
def pair(path_daemon):
    """A writer port connected to a reader port, and a check that the path taken was the one meant."""
    client = plexus.Client(path_daemon.socket)
    name = f"/zc/pair{next(_names)}"
    out = client.open(name + "/out")
    inp = client.open(name + "/in")
    client.connect(name + "/out", name + "/in")
    before = client.stats()["daemon"]["shm_passed"]
    yield out, inp
    passed = client.stats()["daemon"]["shm_passed"] - before
    if path_daemon.path == "shm":
        assert passed > 0, "no large payload went through shared memory"
    else:
        assert passed == 0, "the daemon without shared memory passed payloads through it"


def rng(seed: int) -> numpy.random.Generator:
    return numpy.random.default_rng(seed)


# Each at least 64 KiB, so that it takes the large-payload paths (shm slot, or the socket gather).
LARGE = {
    "uint8-1MiB": lambda: rng(1).integers(0, 256, MIB, dtype=numpy.uint8),
    "float64-C": lambda: rng(2).random((512, 256)),
    "float32-F": lambda: numpy.asfortranarray(rng(3).random((300, 400), dtype=numpy.float32)),
    "int32-big-endian": lambda: rng(4).integers(-(1 << 30), 1 << 30, 70000).astype(">i4"),
    "transposed": lambda: rng(5).random((400, 300)).T,  # Fortran-contiguous: no copy either
    "strided-columns": lambda: rng(6).random((1000, 600), dtype=numpy.float32)[:, ::2],
    "strided-3d": lambda: rng(7).integers(0, 9, (64, 64, 64), dtype=numpy.int16)[::2, 1:, ::-1],
    "structured": lambda: numpy.array([(i, i / 3) for i in range(8000)], dtype=[("id", "<u4"), ("v", "<f8")]),
    "read-only": lambda: numpy.frombuffer(bytes(range(256)) * 1024, dtype=numpy.uint16).reshape(512, 256),
}


@pytest.mark.parametrize("make", LARGE.values(), ids=LARGE.keys())
def test_large_arrays_keep_dtype_shape_and_values(pair, make):
    out, inp = pair
    array = make()
    out.write(array)
    got = inp.read(timeout=10).data
    assert isinstance(got, numpy.ndarray)
    assert got.dtype == array.dtype and got.shape == array.shape
    assert numpy.array_equal(got, array)
    assert got.flags.writeable and not got.flags.owndata  # a view of the received buffer


@pytest.mark.parametrize("flush", [True, False])
def test_the_array_may_change_as_soon_as_write_returns(pair, flush):
    out, inp = pair
    array = rng(8).integers(0, 255, MIB, dtype=numpy.uint8)
    original = array.copy()
    out.write(array, flush=flush)
    array[:] = 255  # the writer's memory is its own again: what was sent must not change
    small = numpy.arange(100, dtype=numpy.int64)  # a small one waits in the send buffer (flush=False)
    out.write(small, flush=flush)
    small[:] = -1
    out.flush()
    assert numpy.array_equal(inp.read(timeout=10).data, original)
    assert numpy.array_equal(inp.read(timeout=10).data, numpy.arange(100, dtype=numpy.int64))


def test_bytes_like_objects_are_sent_from_their_memory_and_may_change_after(pair):
    out, inp = pair
    buffer = bytearray(rng(9).integers(0, 256, MIB, dtype=numpy.uint8).tobytes())
    original = bytes(buffer)
    out.write(buffer)
    buffer[:10] = b"x" * 10
    out.write(memoryview(original)[1000:])
    out.write(b"small")
    got = inp.read(timeout=10).data
    assert isinstance(got, bytes) and got == original
    assert inp.read(timeout=10).data == original[1000:]
    assert inp.read(timeout=10).data == b"small"


def test_a_strided_memoryview_is_refused_as_before(pair):
    out, _ = pair
    with pytest.raises(BufferError):
        out.write(memoryview(bytes(range(100)))[::2])
    out.write(numpy.zeros(MIB, dtype=numpy.uint8))  # the port still works (and the path check has a payload)


def test_a_read_array_stays_valid_across_later_reads_and_recycled_buffers(pair):
    out, inp = pair
    kept = []
    for i in range(24):
        out.write(numpy.full(MIB // 8, i, dtype=numpy.int64))
        got = inp.read(timeout=10).data
        if i % 3 == 0:
            kept.append((i, got))  # the others die here and their buffers are received into again
    for i, array in kept:
        assert array.shape == (MIB // 8,) and (array == i).all(), f"array {i} changed under its reader"


def test_the_buffer_of_a_dropped_array_receives_a_later_one(pair):
    out, inp = pair
    size = MIB + 4096 * 3  # a size of its own: no buffer left by another test fits it as well
    out.write(numpy.ones(size, dtype=numpy.uint8))
    first = inp.read(timeout=10).data
    address = first.__array_interface__["data"][0]
    del first
    # Had the buffer gone back to malloc, this allocation of the blob's size (the .npy header is
    # 128 bytes) would take its memory, and the next message could not be received there.
    blocker = numpy.empty(size + 128, dtype=numpy.uint8)
    out.write(numpy.full(size, 2, dtype=numpy.uint8))
    second = inp.read(timeout=10).data
    assert second.__array_interface__["data"][0] == address, "received into fresh memory again"
    assert (second == 2).all()
    del blocker


def test_other_threads_run_while_a_write_waits_for_a_slow_strict_reader(path_daemon):
    client = plexus.Client(path_daemon.socket)
    name = f"/zc/slow{next(_names)}"
    out = client.open(name + "/out")
    inp = client.open(name + "/in", policy="strict", capacity=1)
    client.connect(name + "/out", name + "/in")
    count = 40  # 40 MiB: far more than the queue, the slots and the socket buffers hold
    failures = []

    def write_all():
        try:
            for i in range(count):
                out.write(numpy.full(MIB, i % 256, dtype=numpy.uint8))
        except Exception as e:  # reported by the main thread
            failures.append(e)

    writer = threading.Thread(target=write_all, daemon=True)
    writer.start()
    # The writer blocks in write() until this thread reads: had it kept the GIL, this read could
    # never run and the writer would never finish.
    for i in range(count):
        message = inp.read(timeout=30)
        assert message is not None, f"message {i} never came"
        assert (message.data == i % 256).all()
    writer.join(timeout=30)
    assert not writer.is_alive() and not failures, failures
