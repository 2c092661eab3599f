"""Every type round-trips: Python -> Python, Python -> C++ (the echo component) -> Python, and
the CLI (plexus write / plexus read) on either side."""

import json
import subprocess

import pytest

import plexus
from conftest import PLEXUS_CLI, wait_for

VALUES = [
    None,
    True,
    False,
    0,
    -1,
    2**63 - 1,
    -(2**63),
    2**64 - 1,
    1.5,
    -0.0,
    "",
    "text with ünïcödé and \"quotes\"",
    b"",
    b"\x00\x01\xffbytes",
    [],
    [1, "two", 3.0, None, [True]],
    {},
    {"x": 1, "y": [2, 3], "nested": {"blob": b"\x00" * 10, "f": 0.25}},
]


def test_python_to_python_keeps_every_type(client):
    out = client.open("/rt/py/out")
    inp = client.open("/rt/py/in")
    client.connect("/rt/py/out", "/rt/py/in")
    for value in VALUES:
        out.write(value)
        message = inp.read(timeout=10)
        assert message is not None, value
        assert message.data == value and type(message.data) is type(value)
    assert message.envelope.source == "/rt/py/out"
    assert message.envelope.seq == len(VALUES)
    assert message.envelope.time > 1e9 and message.envelope.time_ns > 1e18


def test_tuples_bytearrays_and_memoryviews_arrive_as_lists_and_bytes(client):
    out = client.open("/rt/conv/out")
    inp = client.open("/rt/conv/in")
    client.connect("/rt/conv/out", "/rt/conv/in")
    out.write({"t": (1, 2), "b": bytearray(b"ab"), "m": memoryview(b"cd")})
    assert inp.read(timeout=10).data == {"t": [1, 2], "b": b"ab", "m": b"cd"}


def test_python_through_the_cpp_component_keeps_every_type(client, echo):
    out = client.open("/rt/cpp/out")
    inp = client.open("/rt/cpp/back")
    client.connect("/rt/cpp/out", "/cpp/echo/in")
    client.connect("/cpp/echo/out", "/rt/cpp/back")
    expected_type = {type(None): "null", bool: "boolean", int: "number", float: "number", str: "string",
                     bytes: "binary", list: "array", dict: "object"}
    for value in VALUES:
        out.write(value)
        message = inp.read(timeout=10)
        assert message is not None, value
        assert message.data["data"] == value and type(message.data["data"]) is type(value)
        assert message.data["type"] == expected_type[type(value)]
        if isinstance(value, bytes):
            assert message.data["size"] == len(value)
        assert message.envelope.source == "/cpp/echo/out"


def test_cli_writer_reaches_python(daemon, client):
    inp = client.open("/rt/cli/in")
    lines = ['{"x": 1, "y": [2, 3]}', "hello", "42", "null", "[true, 1.5]"]
    result = daemon.cli("write", "/rt/cli/out", "/rt/cli/in", input="\n".join(lines) + "\n")
    assert result.returncode == 0, result.stderr
    got = [inp.read(timeout=10).data for _ in lines]
    assert got == [{"x": 1, "y": [2, 3]}, "hello", 42, None, [True, 1.5]]


def test_python_writer_reaches_the_cli(daemon, client):
    out = client.open("/rt/tocli/out")
    reader = subprocess.Popen([PLEXUS_CLI, "read", "/rt/tocli/in", "--count", "4", "--timeout", "20"],
                              env=daemon.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # The reader is ready when its port exists: then connect, and write.
        wait_for(lambda: client.exists("/rt/tocli/in"), 20, "the CLI reader's port", reader)
        client.connect("/rt/tocli/out", "/rt/tocli/in")
        values = [{"a": [1, 2]}, "text", 7, None]
        for value in values:
            out.write(value)
        stdout, stderr = reader.communicate(timeout=20)
        assert reader.returncode == 0, stderr
        assert [json.loads(line) for line in stdout.splitlines()] == values
    finally:
        reader.kill()
        reader.wait()


def test_what_has_no_message_form_is_a_type_error(client):
    out = client.open("/rt/bad/out")
    with pytest.raises(TypeError):
        out.write(object())
    with pytest.raises(TypeError):
        out.write({1: "int keys"})
    with pytest.raises(ValueError):
        out.write(2**64)


def test_iteration_yields_messages(client):
    out = client.open("/rt/iter/out")
    inp = client.open("/rt/iter/in")
    client.connect("/rt/iter/out", "/rt/iter/in")
    for i in range(3):
        out.write(i)
    got = []
    for message in inp:
        got.append(message.data)
        if len(got) == 3:
            break
    assert got == [0, 1, 2]
