"""Ctrl-C (SIGINT) interrupts a read blocked for ever: KeyboardInterrupt, promptly."""

import signal
import subprocess
import sys
import textwrap

BLOCKED = textwrap.dedent("""
    import sys, plexus
    port = plexus.Client(sys.argv[1]).open("/interrupt/in")
    try:
        print("ready", flush=True)  # inside the try: a signal just after it is still caught
        port.read()
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(7)
""")


def test_sigint_raises_keyboard_interrupt_in_a_blocked_read(daemon):
    process = subprocess.Popen([sys.executable, "-c", BLOCKED, daemon.socket], stdout=subprocess.PIPE,
                               text=True, env=daemon.env)
    try:
        assert process.stdout.readline().strip() == "ready"
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=10) == 7  # the slice is 50 ms; 10 s only bounds a failure
        assert process.stdout.read().strip() == "interrupted"
    finally:
        process.kill()
        process.wait()
