#!/usr/bin/env python3
"""The docs are tests: runs the command blocks of a Markdown file as written (CMakeLists.txt beside
this file registers them as ctests named readme_*).

  run_doc_blocks.py --source DIR --build DIR [--timeout SEC] [--requires PATH]... DOC:SEQUENCE...

Which blocks run: a block (indented or fenced) right after a marker line

    <!-- doc-test: SEQUENCE -->            its lines are shell commands
    <!-- doc-test: SEQUENCE file=NAME -->  its text is written to NAME in the scratch directory
                                           (a Python program the next block runs, say)

with nothing but blank lines between the marker and the block. Unmarked blocks are not run (C++
fragments, output samples, commands for several machines). All the blocks of one SEQUENCE of a
DOC run in order in one bash with `set -euo pipefail`, so what one block starts or exports, the
next one sees, as in the terminal of a reader who types them one after another.

Where they run: a scratch copy of the source tree (so a command that writes into the tree cannot
change the real one), whose `build` is a symlink to the build tree ctest was configured with.
PLEXUS_SOCKET is a socket in the scratch directory and PLEXUS_NAMES a free loopback port, so the
docs' commands, which rely on those defaults, do not meet another test's daemon (MQTT_PORT, another
free loopback port, for a broker a block starts as `mosquitto -p ${MQTT_PORT:-1883}`); discovery is off
(loopback only); TMPDIR is inside the scratch directory, so `mktemp` leaves nothing behind.

Every process a block starts is killed when the sequence ends, also when it fails or times out:
each carries a marker in its environment, and every process that has it is killed, also those that
left the process group (`plexus up` starts components with setsid).

Lines that install or build (./scripts/run, ./scripts/build, apt-get, cmake --install, ...) are
skipped, each with its reason printed: ctest runs after the build, and a test does not install.

Exit status: 0 all passed, 1 a block failed (the failing doc line is named), 77 a --requires path
is missing from the build tree (ctest's SKIP_RETURN_CODE).
"""
import argparse
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid

SKIP = 77

# Commands a doc shows that a test must not run, with the reason printed when one is skipped.
# A line is skipped when its command starts with one of these words.
SKIPPED_COMMANDS = [
    ("./scripts/run", "starts the interactive demo until Ctrl-C; the tour below covers its parts"),
    ("./scripts/test", "runs the whole suite, this test included"),
    ("./scripts/build", "ctest runs after the build; the build tree is the one under test"),
    ("./scripts/deps", "installs packages"),
    ("./scripts/package", "builds a Debian package (tests/install/deb_test.sh covers it)"),
    ("./scripts/bench-peers-setup", "installs other brokers"),
    ("sudo", "needs root and changes the system"),
    ("apt-get", "installs packages"),
    ("cmake --install", "installs into a prefix (ctest -L install covers it)"),
    ("cmake --build", "ctest runs after the build"),
    ("systemctl", "changes the system's services"),
    ("adduser", "changes the system's users"),
]

MARKER = re.compile(r"^\s*<!--\s*doc-test:\s*(?P<sequence>[\w.-]+)(?:\s+file=(?P<file>[\w./-]+))?\s*-->\s*$")
FENCE = re.compile(r"^(?P<indent> {0,3})(?P<fence>```+|~~~+)")


class Block:
    def __init__(self, line, text_lines, file=None):
        self.line = line              # the doc's line number of the block's first line (1-based)
        self.text_lines = text_lines  # the block's lines, without the Markdown indentation or fences
        self.file = file              # write the block to this file instead of running it


def read_code_block(lines, start):
    """The code block starting at lines[start] (after blank lines): (first line number, its lines,
    index after it), or None if what follows is not a code block."""
    i = start
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i == len(lines):
        return None
    fence = FENCE.match(lines[i])
    if fence:
        closing, indent = fence.group("fence"), len(fence.group("indent"))
        body, j = [], i + 1
        while j < len(lines) and not lines[j].lstrip(" ").startswith(closing):
            body.append(lines[j][indent:] if lines[j][:indent].strip() == "" else lines[j].lstrip(" "))
            j += 1
        return i + 2, body, j + 1
    if lines[i].startswith("    "):
        body, j = [], i
        # An indented block runs until a non-blank line with less indentation; blank lines inside it
        # belong to it, trailing ones do not.
        while j < len(lines) and (lines[j].startswith("    ") or not lines[j].strip()):
            body.append(lines[j][4:])
            j += 1
        while body and not body[-1].strip():
            body.pop()
        return i + 1, body, j
    return None


def blocks_of(doc, sequence):
    """The marked blocks of SEQUENCE in the Markdown file DOC, in order."""
    lines = open(doc, encoding="utf-8").read().split("\n")
    found = []
    for number, line in enumerate(lines, start=1):
        marker = MARKER.match(line)
        if not marker or marker.group("sequence") != sequence:
            continue
        block = read_code_block(lines, number)
        if block is None:
            sys.exit(f"{doc}:{number}: the doc-test marker is not followed by a code block")
        first, body, _ = block
        found.append(Block(first, body, marker.group("file")))
    if not found:
        sys.exit(f"{doc}: no block is marked <!-- doc-test: {sequence} -->")
    return found


def skip_reason(command):
    words = command.strip()
    for prefix, reason in SKIPPED_COMMANDS:
        if words == prefix or words.startswith(prefix + " "):
            return reason
    return None


def free_loopback_port():
    # Port 0 picks a free port; the name server binds it a moment later. Another program could take
    # it in between, but nothing else on loopback picks ports this way at the same time.
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def script_for(doc, blocks, scratch, failed_file):
    """The bash script of one sequence, and for each of its lines the doc line it came from."""
    script = [
        "set -euo pipefail",
        # Where a command fails, for the report (set -e ends the script there).
        f"trap 'echo $LINENO > {failed_file}' ERR",
        "set -x",
    ]
    origin = [None] * len(script)
    for block in blocks:
        if block.file:
            target = os.path.join(scratch, block.file)
            os.makedirs(os.path.dirname(target), exist_ok=True)
            with open(target, "w", encoding="utf-8") as out:
                out.write("\n".join(block.text_lines) + "\n")
            print(f"{doc}:{block.line}: written to {block.file}", flush=True)
            continue
        for offset, line in enumerate(block.text_lines):
            reason = skip_reason(line)
            if reason:
                print(f"{doc}:{block.line + offset}: skipped `{line.strip()}`: {reason}", flush=True)
                line = ""
            script.append(line)
            origin.append(block.line + offset)
    return "\n".join(script) + "\n", origin


def marked_pids(mark):
    """Our processes whose environment carries MARK."""
    needle = f"PLEXUS_DOC_TEST_RUN={mark}".encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as environ:
                if needle in environ.read().split(b"\0"):
                    found.append(int(entry))
        except OSError:
            pass  # gone meanwhile, or not ours
    return found


def kill_marked(mark, grace=5.0):
    """SIGTERM to everything the sequence started, SIGKILL to what is left after GRACE seconds."""
    pids = marked_pids(mark)
    for pid in pids:
        with_ignored_error(os.kill, pid, signal.SIGTERM)
    deadline = time.monotonic() + grace
    while pids and time.monotonic() < deadline:
        time.sleep(0.02)  # polling for the processes to be gone, with a deadline
        pids = [pid for pid in marked_pids(mark) if not is_zombie(pid)]
    for pid in pids:
        print(f"doc-test: process {pid} ignored SIGTERM for {grace} s; killing it", flush=True)
        with_ignored_error(os.kill, pid, signal.SIGKILL)


def with_ignored_error(function, *args):
    try:
        function(*args)
    except OSError:
        pass


def is_zombie(pid):
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def run_sequence(source, build, doc_and_sequence, timeout):
    doc_name, sequence = doc_and_sequence.rsplit(":", 1)
    doc = os.path.join(source, doc_name)
    blocks = blocks_of(doc, sequence)
    scratch = tempfile.mkdtemp(prefix=f"plexus-doc-{sequence}-")
    mark = uuid.uuid4().hex
    try:
        tree = os.path.join(scratch, "tree")
        # A copy, not symlinks: a doc command that writes into the tree must not change the source.
        shutil.copytree(source, tree, symlinks=True,
                        ignore=shutil.ignore_patterns(".git", "build", "build-*"))
        os.symlink(os.path.abspath(build), os.path.join(tree, "build"))
        os.makedirs(os.path.join(scratch, "tmp"))
        failed_file = os.path.join(scratch, "failed-line")
        script, origin = script_for(doc_name, blocks, tree, failed_file)
        script_path = os.path.join(scratch, "sequence.sh")
        with open(script_path, "w") as out:
            out.write(script)

        env = {k: v for k, v in os.environ.items() if not k.startswith("PLEXUS_")}
        env.update(PLEXUS_SOCKET=os.path.join(scratch, "plexusd.sock"),
                   PLEXUS_NAMES=f"127.0.0.1:{free_loopback_port()}",
                   PLEXUS_DISCOVERY="off",
                   MQTT_PORT=str(free_loopback_port()),
                   PLEXUS_DOC_TEST_RUN=mark,
                   TMPDIR=os.path.join(scratch, "tmp"))
        print(f"== {doc_name}, sequence '{sequence}': {len(blocks)} blocks, in {tree}; "
              f"PLEXUS_SOCKET={env['PLEXUS_SOCKET']} PLEXUS_NAMES={env['PLEXUS_NAMES']}", flush=True)
        # stdin is /dev/null: a command waiting for typed input ends at EOF instead of hanging.
        process = subprocess.Popen(["bash", script_path], cwd=tree, env=env, stdin=subprocess.DEVNULL,
                                   start_new_session=True)
        try:
            status = process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            print(f"FAILED: {doc_name} '{sequence}' did not finish within {timeout} s", flush=True)
            return 1
        finally:
            kill_marked(mark)
            process.wait()
        if status != 0:
            where = ""
            if os.path.exists(failed_file):
                line = int(open(failed_file).read().split()[0])
                if 0 < line <= len(origin) and origin[line - 1]:
                    doc_line = origin[line - 1]
                    where = f" at {doc_name}:{doc_line}: {script.splitlines()[line - 1].strip()}"
            print(f"FAILED: {doc_name} '{sequence}' exited {status}{where}", flush=True)
            return 1
        print(f"== {doc_name}, sequence '{sequence}': passed", flush=True)
        return 0
    finally:
        kill_marked(mark)
        shutil.rmtree(scratch, ignore_errors=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--source", required=True, help="the source tree (the docs and what they use)")
    parser.add_argument("--build", required=True, help="the build tree, seen as build/ by the docs")
    parser.add_argument("--timeout", type=float, default=120, help="seconds each sequence may take")
    parser.add_argument("--requires", action="append", default=[],
                        help="a path in the build tree; if missing, skip (exit 77)")
    parser.add_argument("sequences", nargs="+", metavar="DOC:SEQUENCE")
    args = parser.parse_args()
    # ctest (or Ctrl-C) stopping the runner still runs the clean-up in run_sequence's finally.
    signal.signal(signal.SIGTERM, lambda number, frame: sys.exit(f"FAILED: stopped by signal {number}"))
    for required in args.requires:
        if not os.path.exists(os.path.join(args.build, required)):
            print(f"SKIPPED: {required} is not in the build tree {args.build}", flush=True)
            return SKIP
    failures = sum(run_sequence(os.path.abspath(args.source), args.build, item, args.timeout)
                   for item in args.sequences)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
