"""asyncio: read_async and async for, two ports at once, timeouts, and cancellation without loss."""

import asyncio

import plexus


def test_two_ports_read_at_once(client):
    a_out, b_out = client.open("/aio/a/out"), client.open("/aio/b/out")
    a_in, b_in = client.open("/aio/a/in"), client.open("/aio/b/in")
    client.connect("/aio/a/out", "/aio/a/in")
    client.connect("/aio/b/out", "/aio/b/in")

    async def collect(port, count):
        got = []
        async for message in port:
            got.append(message.data)
            if len(got) == count:
                return got

    async def main():
        readers = asyncio.gather(collect(a_in, 50), collect(b_in, 50))
        for i in range(50):  # interleaved, while both readers wait
            a_out.write(["a", i])
            b_out.write(["b", i])
            await asyncio.sleep(0)
        return await asyncio.wait_for(readers, 30)

    got_a, got_b = asyncio.run(main())
    assert got_a == [["a", i] for i in range(50)]
    assert got_b == [["b", i] for i in range(50)]


def test_read_async_times_out_with_none_without_blocking_the_loop(client):
    quiet = client.open("/aio/quiet")

    async def main():
        ticks = 0

        async def ticker():
            nonlocal ticks
            while True:
                ticks += 1
                await asyncio.sleep(0.01)

        task = asyncio.create_task(ticker())
        result = await quiet.read_async(timeout=0.3)
        task.cancel()
        return result, ticks

    result, ticks = asyncio.run(main())
    assert result is None
    assert ticks >= 5  # the loop ran while the read waited


def test_a_cancelled_read_loses_no_message(client):
    out = client.open("/aio/cancel/out")
    inp = client.open("/aio/cancel/in")
    client.connect("/aio/cancel/out", "/aio/cancel/in")

    async def main():
        waiting = asyncio.create_task(inp.read_async())
        await asyncio.sleep(0.05)
        waiting.cancel()
        out.write("kept")
        return await inp.read_async(timeout=10)

    assert asyncio.run(main()).data == "kept"


def test_async_iteration_ends_when_the_port_closes(client):
    inp = client.open("/aio/closing")
    inp.close()

    async def main():
        return [message async for message in inp]

    assert asyncio.run(main()) == []
