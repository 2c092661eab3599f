"""Errors are plexus.Error subclasses by the C++ ErrorCode, with the messages the CLI prints."""

import builtins

import pytest

import plexus


def cli_message(result):
    assert result.stderr.startswith("plexus: "), result.stderr
    return result.stderr.strip().splitlines()[-1][len("plexus: "):]


def test_a_bad_port_name_is_a_usage_error_with_the_cli_message(daemon, client):
    with pytest.raises(plexus.UsageError) as raised:
        client.open("no/slash")
    result = daemon.cli("read", "no/slash", "--count", "1")
    assert result.returncode == 2
    assert str(raised.value) == cli_message(result)
    assert raised.value.code == 2
    assert isinstance(raised.value, plexus.Error) and isinstance(raised.value, ValueError)
    with pytest.raises(plexus.UsageError):
        client.connect("/ok", "bad name")


def test_a_refused_connect_is_a_refused_error_with_the_cli_message(daemon, client):
    src = client.open("/err/src")
    with pytest.raises(plexus.RefusedError) as raised:
        client.connect("/err/src", "/err/nobody/here")
    result = daemon.cli("connect", "/err/src", "/err/nobody/here")
    assert result.returncode == 4
    assert str(raised.value) == cli_message(result)
    assert raised.value.code == 4 and isinstance(raised.value, ConnectionError)
    src.close()


def test_no_daemon_is_a_refused_error_saying_where_it_looked(tmp_path):
    with pytest.raises(plexus.RefusedError) as raised:
        plexus.Client(str(tmp_path / "none.sock"))
    assert "none.sock" in str(raised.value)


def test_bad_arguments_and_closed_ports_are_usage_errors(client):
    with pytest.raises(plexus.UsageError):
        client.open("/err/policy", policy="newest")
    port = client.open("/err/closed")
    port.close()
    with pytest.raises(plexus.UsageError, match="closed"):
        port.write(1)
    with pytest.raises(plexus.UsageError, match="closed"):
        port.read(timeout=0)
    with pytest.raises(plexus.UsageError):
        client.open("/err/negative").read(timeout=-1)


def test_the_error_classes_are_also_the_builtin_kinds():
    assert issubclass(plexus.TimeoutError, builtins.TimeoutError)
    assert issubclass(plexus.NotFoundError, LookupError)
    assert [cls.code for cls in (plexus.NotFoundError, plexus.UsageError, plexus.TimeoutError,
                                 plexus.RefusedError)] == [1, 2, 3, 4]


def test_control_queries(daemon, client):
    there = client.open("/err/there")  # a port lives as long as its object
    assert client.exists("/err/there") and not client.exists("/err/not/there")
    assert client.lookup("/err/there")["node"] == "pytest"
    assert client.lookup("/err/not/there") is None
    assert any(p["name"] == "/err/there" for p in client.stats()["ports"])
    out = client.open("/err/a")
    b = client.open("/err/b")
    client.connect("/err/a", "/err/b")
    assert client.exists("/err/a", "/err/b")
    client.disconnect("/err/a", "/err/b")
    assert not client.exists("/err/a", "/err/b")
    events = client.events("/err/b")
    assert isinstance(events, dict)
    del out, b, there


def test_a_message_over_the_frame_limit_is_refused_before_it_is_sent_and_the_port_goes_on(client):
    # The daemon's limit is 64 MiB; such a write used to return normally while the daemon cut the
    # session off, and libplexus sent it again after every reconnection.
    out = client.open("/err/large/out")
    into = client.open("/err/large/in")
    client.connect("/err/large/out", "/err/large/in")
    with pytest.raises(plexus.RefusedError, match="frame limit"):
        out.write(bytes(64 * 1024 * 1024 + 1))
    out.write("after")
    assert into.read(timeout=10).data == "after"


def test_a_message_nested_deeper_than_readers_decode_is_refused(client):
    out = client.open("/err/deep")
    deep = 1
    for _ in range(129):
        deep = [deep]
    with pytest.raises(ValueError, match="deeper than 128 levels"):
        out.write(deep)
    out.write(deep[0])  # 128 levels: accepted
