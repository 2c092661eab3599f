"""NumPy arrays on the wire: a blob holding the array as a `.npy` file (NumPy's own format).

The blob is the `.npy` header (magic ``\\x93NUMPY``, version, the header length, a Python-literal
dict with ``descr``, ``fortran_order`` and ``shape``, padded so the data starts at a multiple of
64 bytes) followed by the array's raw bytes. Any NumPy can read it (``numpy.load``), any C++ .npy
reader can, and it is one untagged byte string, so a large array takes libplexus's fast paths
(shared memory between clients of one daemon, received straight into the message's buffer).

The compiled extension calls these two functions; both are cached, since a stream of frames has
one header over and over and parsing a Python literal costs more than copying a small frame.
"""

from __future__ import annotations

import ast
import functools

import numpy

MAGIC = b"\x93NUMPY"
_ALIGN = 64  # numpy.lib.format.ARRAY_ALIGN: the data starts at a multiple of this


@functools.lru_cache(maxsize=256)
def encode_header(dtype: numpy.dtype, shape: tuple, fortran_order: bool) -> bytes:
    """The .npy header (magic to padding) for an array of this dtype, shape and order."""
    if dtype.hasobject:
        raise TypeError("cannot send a NumPy array of Python objects (dtype object); convert it first")
    descr = numpy.lib.format.dtype_to_descr(dtype)
    text = "{'descr': %r, 'fortran_order': %r, 'shape': %r, }" % (descr, fortran_order, tuple(shape))
    for version, length_bytes in ((1, 2), (2, 4)):
        preamble = len(MAGIC) + 2 + length_bytes
        padding = -(preamble + len(text) + 1) % _ALIGN
        body = (text + " " * padding + "\n").encode("latin1")
        if len(body) < 1 << (8 * length_bytes):
            return MAGIC + bytes([version, 0]) + len(body).to_bytes(length_bytes, "little") + body
    raise ValueError("array header too long")


@functools.lru_cache(maxsize=256)
def decode_header(body: bytes):
    """(dtype, shape, fortran_order) from the dict text of a .npy header; None if it is not one."""
    try:
        fields = ast.literal_eval(body.decode("latin1"))
        dtype = numpy.lib.format.descr_to_dtype(fields["descr"])
        shape = tuple(int(n) for n in fields["shape"])
        fortran_order = bool(fields["fortran_order"])
    except Exception:  # anything malformed: the blob is handed over as bytes instead
        return None
    if dtype.hasobject or any(n < 0 for n in shape):
        return None  # pickled objects are never unpickled from the wire
    return dtype, shape, fortran_order
