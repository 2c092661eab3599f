"""Zero-copy messages from Python: a Loan written in place (a writable memoryview or NumPy array of
the port's shared memory) and sent, and a MessageView read in place (a read-only memoryview), its
slot released when the view is. The daemon's counters prove the payload was never copied."""

import itertools

import numpy
import pytest

import plexus
from conftest import Daemon

MIB = 1 << 20
_names = itertools.count()


@pytest.fixture(scope="module")
def daemon(tmp_path_factory):
    started = Daemon(tmp_path_factory.mktemp("plexusd-loans"))
    try:
        yield started
    finally:
        started.stop()


@pytest.fixture
def pair(daemon):
    writer = plexus.Client(daemon.socket)
    reader = plexus.Client(daemon.socket)
    name = f"/loans/pair{next(_names)}"
    out = writer.open(name + "/out")
    inp = reader.open(name + "/in")
    writer.connect(name + "/out", name + "/in")
    yield writer, out, inp
    out.close()
    inp.close()


def test_a_loan_filled_through_numpy_is_read_in_place(pair):
    writer, out, inp = pair
    before = writer.stats()["daemon"]
    for i in range(5):
        loan = out.loan(MIB)
        assert loan.in_shared_memory
        assert len(loan) == MIB
        array = numpy.frombuffer(loan, dtype=numpy.uint32)
        array[:] = numpy.arange(MIB // 4, dtype=numpy.uint32) + i
        del array
        out.send_loan(loan)
        with inp.read_view(timeout=20) as view:
            assert view.in_place
            assert view.envelope.source == out.name
            got = numpy.frombuffer(view, dtype=numpy.uint32)
            assert not got.flags.writeable
            assert numpy.array_equal(got, numpy.arange(MIB // 4, dtype=numpy.uint32) + i)
            del got
    after = writer.stats()["daemon"]
    assert after["shm_passed"] - before["shm_passed"] == 5
    assert after["shm_copied"] == before["shm_copied"]


def test_a_sent_loan_and_a_released_view_cannot_be_used_again(pair):
    _, out, inp = pair
    loan = out.loan(1000)
    memoryview(loan)[:] = b"x" * 1000
    out.send_loan(loan)
    assert len(memoryview(loan)) == 0  # sent: its memory is the message's now
    with pytest.raises(plexus.UsageError):
        out.send_loan(loan)
    view = inp.read_view(timeout=20)
    assert bytes(memoryview(view)) == b"x" * 1000
    assert view.value() == b"x" * 1000
    view.release()
    assert len(memoryview(view)) == 0
    with pytest.raises(plexus.UsageError):
        view.value()


def test_a_view_of_a_small_message_holds_its_value(pair):
    _, out, inp = pair
    out.write({"n": 1})
    view = inp.read_view(timeout=20)
    assert not view.in_place
    assert view.value() == {"n": 1}
    assert inp.read_view(timeout=0) is None
