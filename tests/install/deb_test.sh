#!/usr/bin/env bash
# Installs the Debian package built by scripts/package, checks it, removes it and purges it.
# Run by hand as root on a machine (or container) you may install packages on; not part of ctest,
# which should not change the system it runs on:  tests/install/deb_test.sh [build-package/plexus_*.deb]
set -euo pipefail
cd "$(dirname "$0")/../.."
deb=$(realpath "${1:-$(ls build-package/plexus_*.deb | head -n1)}")
scratch=$(mktemp -d /tmp/plexus-deb-test-XXXXXX)
daemon_pid=""
cleanup() {
    [ -n "$daemon_pid" ] && kill "$daemon_pid" 2>/dev/null && wait "$daemon_pid" 2>/dev/null || true
    rm -rf "$scratch"
    if dpkg -s plexus >/dev/null 2>&1; then  # installed, or removed with its config kept
        echo "deb_test: purging plexus after a failure"
        DEBIAN_FRONTEND=noninteractive apt-get remove --purge -y -qq plexus >/dev/null || true
    fi
}
trap cleanup EXIT
step() { echo "== $*"; }

step "apt-get install $deb"
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$deb"
dpkg-query -W -f='${Package} ${Version} ${Architecture}\nDepends: ${Depends}\nConffiles:\n${Conffiles}\n' plexus

step "programs run from /usr/bin; the Python module imports in Debian's python3 (not a pyenv one on PATH)"
for program in plexusd plexus-names plexus plexus-bench plexus-sim-world plexus-bridge; do
    command -v "$program" | grep -qx "/usr/bin/$program"
    "$program" --help >/dev/null
done
plexus-timeline-svg --help >/dev/null
/usr/bin/python3 -c 'import plexus; print("python module:", plexus.__file__)'

step "user, config and units"
getent passwd plexus
test -f /etc/plexus/plexusd.json
test -f /etc/plexus/plexus-names.env
test -f /lib/systemd/system/plexusd.service
test -f /lib/systemd/system/plexus-names.service
if command -v systemd-analyze >/dev/null; then
    systemd-analyze verify /lib/systemd/system/plexusd.service /lib/systemd/system/plexus-names.service
fi

step "plexusd as user plexus with the installed config and monitors, and examples/cpp against it"
chown plexus:plexus "$scratch"
runuser -u plexus -- /usr/bin/plexusd --embedded-names --names 127.0.0.1:0 --listen 127.0.0.1:0 \
    --socket "$scratch/plexusd.sock" --ready-file "$scratch/ready.json" --config /etc/plexus/plexusd.json \
    --scripts /usr/share/plexus/monitors >"$scratch/plexusd.log" 2>&1 &
daemon_pid=$!
for _ in $(seq 1000); do  # poll for the ready file, up to ~10 s
    [ -s "$scratch/ready.json" ] && break
    kill -0 "$daemon_pid" 2>/dev/null || { cat "$scratch/plexusd.log"; exit 1; }
    sleep 0.01
done
cat "$scratch/ready.json"
cmake -S examples/cpp -B "$scratch/example" -G Ninja >/dev/null   # find_package from /usr, no prefix
cmake --build "$scratch/example" >/dev/null
g++ -std=c++20 examples/cpp/counter.cpp -o "$scratch/counter-pkg" $(pkg-config --cflags --libs plexus)
PLEXUS_SOCKET="$scratch/plexusd.sock" "$scratch/example/counter" 2
PLEXUS_SOCKET="$scratch/plexusd.sock" "$scratch/counter-pkg" 2
PLEXUS_SOCKET="$scratch/plexusd.sock" /usr/bin/python3 examples/python/counter.py 2
kill "$daemon_pid"; wait "$daemon_pid" || true; daemon_pid=""

step "apt-get remove: programs gone, conffiles and user kept"
DEBIAN_FRONTEND=noninteractive apt-get remove -y -qq plexus >/dev/null
fail() { echo "deb_test: FAILED: $*"; exit 1; }
if [ -e /usr/bin/plexusd ] || [ -e /usr/lib/x86_64-linux-gnu/libplexus.so.0 ]; then fail "programs still installed"; fi
test -f /etc/plexus/plexusd.json
getent passwd plexus >/dev/null

step "apt-get remove --purge: config, state and user gone"
DEBIAN_FRONTEND=noninteractive apt-get remove --purge -y -qq plexus >/dev/null
test ! -e /etc/plexus
test ! -e /var/lib/plexus
if getent passwd plexus; then fail "user plexus left after purge"; fi
if getent group plexus; then fail "group plexus left after purge"; fi
step "deb_test: all passed"
