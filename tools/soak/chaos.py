"""What a hostile or broken network does to the listeners: garbage bytes and floods of connects."""
import random
import socket


def split_address(address):
    host, port = address.rsplit(":", 1)
    return host, int(port)


def send_garbage(address, rng):
    """One TCP connection sending 16 B..4 KiB of random bytes (sometimes a frame-like prefix), then
    a UDP datagram of random bytes to the same port. Returns the bytes sent."""
    host, port = split_address(address)
    size = rng.randint(16, 4096)
    junk = bytes(rng.getrandbits(8) for _ in range(size))
    if rng.random() < 0.3:
        junk = b"PLXS" + junk  # looks like the start of something, to get past the first check
    sent = 0
    try:
        with socket.create_connection((host, port), timeout=2) as connection:
            connection.sendall(junk)
            sent += len(junk)
    except OSError:
        pass  # refused or reset: the listener is allowed to hang up on garbage
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as datagram:
            datagram.sendto(junk[:1400], (host, port))
            sent += min(len(junk), 1400)
    except OSError:
        pass
    return sent


def flood_connects(address, count):
    """Opens `count` TCP connections to one listener at once, then closes them all. Returns how
    many were accepted by the kernel."""
    host, port = split_address(address)
    opened = []
    try:
        for _ in range(count):
            try:
                opened.append(socket.create_connection((host, port), timeout=2))
            except OSError:
                break
    finally:
        for connection in opened:
            connection.close()
    return len(opened)


def pick(rng, choices):
    return choices[rng.randrange(len(choices))]


__all__ = ["send_garbage", "flood_connects", "pick", "random"]
