"""Request/reply from Python: request, serve, request_async with many calls in flight, and the
errors a call can end with (docs/CALLS.md)."""

import asyncio

import numpy
import pytest

import plexus


def test_a_call_is_answered_with_the_handlers_value(client):
    with client.serve("/py/calls/double", lambda value: {"twice": value["n"] * 2}):
        assert client.request("/py/calls/double", {"n": 21}) == {"twice": 42}
        assert client.request("/py/calls/double", {"n": -1}, timeout=5.0) == {"twice": -2}


def test_every_payload_type_comes_back(client):
    values = [None, True, 0, -7, 2**40, 3.25, "text", "", [1, "a", None], {"k": {"n": [1, 2]}}, b"\x00\x01\x02"]
    with client.serve("/py/calls/echo", lambda value: value):
        for value in values:
            assert client.request("/py/calls/echo", value) == value
        blob = numpy.arange(1 << 18, dtype=numpy.uint8)
        back = client.request("/py/calls/echo", blob.tobytes())
        assert bytes(back) == blob.tobytes()


def test_a_handler_that_raises_fails_the_call_with_its_text(client):
    def broken(value):
        raise ValueError("camera not calibrated")

    with client.serve("/py/calls/broken", broken):
        with pytest.raises(plexus.RefusedError, match="camera not calibrated"):
            client.request("/py/calls/broken", 1)


def test_a_port_nobody_serves_is_refused_at_once(client):
    plain = client.open("/py/calls/plain")
    with pytest.raises(plexus.RefusedError, match="is not served"):
        client.request("/py/calls/plain", 1, timeout=30.0)
    plain.close()


def test_a_slow_server_is_a_timeout(client):
    import time

    def slow(value):
        time.sleep(1.0)
        return value

    with client.serve("/py/calls/slow", slow):
        with pytest.raises(plexus.TimeoutError):
            client.request("/py/calls/slow", 1, timeout=0.2)


def test_request_async_keeps_many_calls_in_flight(client):
    with client.serve("/py/calls/square", lambda value: value * value):

        async def main():
            return await asyncio.wait_for(
                asyncio.gather(*(client.request_async("/py/calls/square", n) for n in range(500))), 60
            )

        assert asyncio.run(main()) == [n * n for n in range(500)]


def test_request_async_raises_what_request_raises(client):
    async def main():
        with pytest.raises(plexus.RefusedError):
            await client.request_async("/py/calls/nobody-here", 1)

    asyncio.run(main())
