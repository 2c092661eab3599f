#!/usr/bin/env python3
"""The daemon's layers include only downwards (README "Layout", STYLE.md's next layout).

Every daemon target exports the same include root (daemon/), so a header of a higher layer still
compiles when included from a lower one: the link targets alone do not fence the layers. This
reads every #include "..." under daemon/ and fails, naming file and line, on one that runs upwards.

Usage: check_daemon_layers.py DAEMON_DIR
"""
import os
import re
import sys

# Each layer (a folder of daemon/) and the layers it may include besides itself.
MAY_INCLUDE = {
    "arbitration": set(),
    "core": {"arbitration"},
    "monitor": {"core", "arbitration"},
    "net": {"core", "arbitration"},
    "record": {"core", "arbitration"},
    "names": {"net", "core", "arbitration"},
    # control/ and inspect/ are one library and use each other: the views read the control host.
    "control": {"inspect", "names", "net", "monitor", "record", "core", "arbitration"},
    "inspect": {"control", "names", "net", "monitor", "record", "core", "arbitration"},
    "web": {"control", "inspect", "names", "net", "monitor", "record", "core", "arbitration"},
    "app": {"web", "control", "inspect", "names", "net", "monitor", "record", "core", "arbitration"},
}
# Single headers a layer may take from another it otherwise may not (with the reason).
EXCEPTIONS = {
    ("monitor", "net/asio.hpp"),  # the strands monitors run on: Asio's one include point
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def layer_of(path):
    return path.split("/", 1)[0] if "/" in path else None


def main():
    root = os.path.abspath(sys.argv[1])
    problems = []
    files = 0
    for folder, _, names in os.walk(root):
        for name in sorted(names):
            if not name.endswith((".cpp", ".hpp", ".h")):
                continue
            path = os.path.relpath(os.path.join(folder, name), root)
            layer = layer_of(path)
            if layer is None:
                problems.append(f"daemon/{path}: a source outside every layer (put it in one)")
                continue
            if layer not in MAY_INCLUDE:
                problems.append(f"daemon/{path}: layer '{layer}' is not in {os.path.basename(__file__)}")
                continue
            files += 1
            with open(os.path.join(root, path), encoding="utf-8") as source:
                for number, line in enumerate(source, 1):
                    match = INCLUDE.match(line)
                    if not match:
                        continue
                    included = match.group(1)
                    beside = os.path.normpath(os.path.join(os.path.dirname(path), included))
                    if os.path.exists(os.path.join(root, beside)):
                        target = beside  # relative to the including file ("../core/port.hpp")
                    elif os.path.exists(os.path.join(root, included)):
                        target = included  # from the include root ("core/port.hpp")
                    else:
                        continue  # not the daemon's ("plexus/proto/...", generated files)
                    other = layer_of(target)
                    if other == layer or other in MAY_INCLUDE[layer] or (layer, target) in EXCEPTIONS:
                        continue
                    problems.append(f"daemon/{path}:{number}: {layer}/ includes {target}, "
                                    f"a header of {other + '/' if other else 'the top level'}, which is above it")
    for problem in problems:
        print(problem)
    print(f"check_daemon_layers: {files} files, {len(problems)} upward includes")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
