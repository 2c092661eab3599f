"""NumPy arrays travel as blobs holding a .npy file: dtype, shape and order kept, read back as an
array viewing the received memory; a 25 MB image crosses through shared memory intact."""

import io
import itertools

import numpy
import pytest

import plexus

ARRAYS = [
    numpy.arange(12, dtype=numpy.float32).reshape(3, 4),
    numpy.arange(24, dtype=numpy.uint8).reshape(2, 3, 4),
    numpy.asfortranarray(numpy.arange(6, dtype=">i8").reshape(2, 3)),
    numpy.arange(20, dtype=numpy.int16)[::3],  # not contiguous: sent as a contiguous copy
    numpy.zeros((0, 5), dtype=numpy.float64),
    numpy.array([True, False]),
    numpy.array([1 + 2j, 3 - 4j], dtype=numpy.complex128),
    numpy.array(3.5, dtype=numpy.float16),  # zero dimensions
    numpy.array([(1, 2.5)], dtype=[("id", "<u4"), ("score", "<f8")]),  # structured
]


_names = itertools.count()


@pytest.fixture
def pair(client):
    name = f"/np/pair{next(_names)}"
    out = client.open(name + "/out")
    inp = client.open(name + "/in")
    client.connect(name + "/out", name + "/in")
    return out, inp


@pytest.mark.parametrize("array", ARRAYS, ids=lambda a: f"{a.dtype.str}{a.shape}")
def test_arrays_keep_dtype_shape_and_values(pair, array):
    out, inp = pair
    out.write(array)
    got = inp.read(timeout=10).data
    assert isinstance(got, numpy.ndarray)
    assert got.dtype == array.dtype and got.shape == array.shape
    assert numpy.array_equal(got, array)


def test_the_array_read_views_the_received_blob(pair):
    out, inp = pair
    out.write(numpy.ones(1000, dtype=numpy.float64))
    got = inp.read(timeout=10).data
    assert not got.flags.owndata and got.base is not None  # no copy: the message's buffer
    assert got.flags.writeable
    got[0] = 5.0  # ours to change
    assert got.sum() == 1004.0


def test_arrays_inside_maps_and_numpy_scalars(pair):
    out, inp = pair
    image = numpy.full((4, 4), 7, dtype=numpy.uint16)
    out.write({"frame": numpy.int64(3), "gain": numpy.float32(0.5), "image": image})
    got = inp.read(timeout=10).data
    assert got["frame"] == 3 and got["gain"] == 0.5
    assert numpy.array_equal(got["image"], image) and got["image"].dtype == numpy.uint16


def test_the_blob_is_a_npy_file_that_numpy_load_reads(pair):
    out, inp = pair
    array = numpy.linspace(0, 1, 7, dtype=numpy.float32)
    # A reader that sees bytes: what Python sends is exactly a .npy file.
    out.write({"raw": bytes(memoryview(numpy.lib.format.__name__.encode()))})  # plain bytes stay bytes
    assert isinstance(inp.read(timeout=10).data["raw"], bytes)
    buffer = io.BytesIO()
    numpy.save(buffer, array)
    out.write(buffer.getvalue())  # a .npy file written by numpy.save arrives as the array
    got = inp.read(timeout=10).data
    assert numpy.array_equal(got, array)


def test_arrays_cross_the_cpp_component_as_blobs(client, echo):
    out = client.open("/np/cpp/out")
    back = client.open("/np/cpp/back")
    client.connect("/np/cpp/out", "/cpp/echo/in")
    client.connect("/cpp/echo/out", "/np/cpp/back")
    array = numpy.arange(100, dtype="<f4").reshape(10, 10)
    out.write(array)
    got = back.read(timeout=10).data
    assert got["type"] == "binary"
    assert got["size"] == 128 + array.nbytes  # a 64-byte-aligned .npy header, then the data
    assert numpy.array_equal(got["data"], array)


def test_a_25_mb_image_crosses_through_shared_memory_intact(daemon, client):
    out = client.open("/np/big/out")
    inp = client.open("/np/big/in")
    client.connect("/np/big/out", "/np/big/in")
    before = client.stats()["daemon"]
    rng = numpy.random.default_rng(16)
    image = rng.integers(0, 256, size=(2500, 2500, 4), dtype=numpy.uint8)  # 25,000,000 bytes
    out.write(image)
    got = inp.read(timeout=30).data
    assert got.shape == image.shape and got.dtype == image.dtype
    assert numpy.array_equal(got, image)
    after = client.stats()["daemon"]
    assert after["shm_passed"] > before["shm_passed"], after  # passed in place, not through the socket
    assert after["shm_regions"] >= 1
