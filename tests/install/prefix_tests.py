#!/usr/bin/env python3
"""Plexus installed into a prefix, used the way a user would (ctest runs each step; CMakeLists.txt).

  install  PREFIX BUILD       cmake --install BUILD --prefix PREFIX (the main build, not a second one)
  cpp      PREFIX SOURCE CXX  build examples/cpp with find_package and with pkg-config, run both
                              against a plexusd started from PREFIX
  python   PREFIX SOURCE      run examples/python with only PREFIX's package on PYTHONPATH
  units    PREFIX             systemd-analyze verify the installed units
  cleanup  PREFIX             remove PREFIX

Every step cleans up its own temporary directories and processes, also when it fails. Nothing
sleeps for a fixed time: waits poll a condition until a deadline.
"""
import contextlib
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

SKIP = 77  # ctest's SKIP_RETURN_CODE for these tests
CMAKE = os.environ.get("PLEXUS_CMAKE", "cmake")  # the cmake that configured the project


def run(command, **kwargs):
    """Runs a command, echoing it, and fails the step with its output if it fails."""
    print("+", " ".join(command), flush=True)
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kwargs)
    print(result.stdout, end="", flush=True)
    if result.returncode != 0:
        sys.exit(f"FAILED ({result.returncode}): {' '.join(command)}")
    return result.stdout


def clean_env(**extra):
    """The environment without anything that could find the build tree instead of the prefix."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("LD_LIBRARY_PATH", "PYTHONPATH", "PYTHONHOME", "PKG_CONFIG_PATH", "CMAKE_PREFIX_PATH",
                        "PLEXUS_SOCKET", "PLEXUS_NAMES", "PLEXUS_CONFIG")}
    env.update(extra)
    return env


@contextlib.contextmanager
def installed_daemon(prefix):
    """A plexusd from PREFIX with its own name server on free loopback ports; yields the environment
    that reaches it (PLEXUS_SOCKET, PLEXUS_NAMES)."""
    with tempfile.TemporaryDirectory(prefix="plexus-install-test-") as scratch:
        ready = os.path.join(scratch, "ready.json")
        socket = os.path.join(scratch, "plexusd.sock")
        log = open(os.path.join(scratch, "plexusd.log"), "w+")
        command = [os.path.join(prefix, "bin", "plexusd"), "--embedded-names", "--names", "127.0.0.1:0",
                   "--listen", "127.0.0.1:0", "--socket", socket, "--ready-file", ready,
                   "--config", os.path.join(prefix, "etc", "plexus", "plexusd.json"),
                   "--scripts", os.path.join(prefix, "share", "plexus", "monitors")]
        print("+", " ".join(command), flush=True)
        daemon = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=clean_env())
        try:
            deadline = time.monotonic() + 10
            while not os.path.exists(ready) or not open(ready).read().strip():
                if daemon.poll() is not None or time.monotonic() > deadline:
                    log.seek(0)
                    sys.exit("FAILED: the installed plexusd did not become ready:\n" + log.read())
                time.sleep(0.01)  # polling the ready file, not waiting for time to pass
            serving = json.loads(open(ready).read())
            print("plexusd ready:", serving, flush=True)
            yield {"PLEXUS_SOCKET": socket, "PLEXUS_NAMES": serving["names"]}
        finally:
            daemon.terminate()
            try:
                daemon.wait(timeout=5)
            except subprocess.TimeoutExpired:
                daemon.kill()
                daemon.wait()
            log.close()


def install(prefix, build):
    shutil.rmtree(prefix, ignore_errors=True)
    run([CMAKE, "--install", build, "--prefix", prefix])
    # The installed programs find libplexus through their RPATH, with nothing in the environment.
    run([os.path.join(prefix, "bin", "plexus"), "--help"], env=clean_env())


def libdir_of(prefix):
    """lib or lib/<multiarch>, whichever GNUInstallDirs chose: where libplexus.so is."""
    found = glob.glob(os.path.join(prefix, "lib*", "**", "libplexus.so"), recursive=True)
    if not found:
        sys.exit(f"FAILED: no libplexus.so under {prefix}")
    return os.path.dirname(found[0])


def cpp(prefix, source, cxx):
    example = os.path.join(source, "examples", "cpp")
    libdir = libdir_of(prefix)
    with tempfile.TemporaryDirectory(prefix="plexus-example-cpp-") as scratch:
        # find_package(Plexus) from the prefix only (no package registry, no other prefix).
        build = os.path.join(scratch, "cmake-build")
        run([CMAKE, "-S", example, "-B", build, "-G", "Ninja", f"-DCMAKE_CXX_COMPILER={cxx}",
             f"-DCMAKE_PREFIX_PATH={prefix}", "-DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF"], env=clean_env())
        found_at = [line for line in open(os.path.join(build, "CMakeCache.txt")) if line.startswith("Plexus_DIR:")]
        if not found_at or not found_at[0].split("=", 1)[1].strip().startswith(prefix):
            sys.exit(f"FAILED: find_package(Plexus) did not use {prefix}: {found_at}")
        run([CMAKE, "--build", build], env=clean_env())

        # pkg-config, as the example's README shows it.
        pkg_env = clean_env(PKG_CONFIG_PATH=os.path.join(libdir, "pkgconfig"))
        flags = run(["pkg-config", "--cflags", "--libs", "plexus"], env=pkg_env).split()
        pkg_counter = os.path.join(scratch, "counter-pkg-config")
        run([cxx, "-std=c++20", os.path.join(example, "counter.cpp"), "-o", pkg_counter, *flags], env=pkg_env)

        with installed_daemon(prefix) as daemon:
            # CMake puts the imported library's directory in the build-tree RPATH; the pkg-config
            # build needs LD_LIBRARY_PATH, as the README says.
            run([os.path.join(build, "counter"), "3"], env=clean_env(**daemon))
            run([pkg_counter, "3"], env=clean_env(**daemon, LD_LIBRARY_PATH=libdir))
            # The installed CLI reaches the installed daemon's name server (the example's ports
            # are gone with it, so the listing is empty).
            run([os.path.join(prefix, "bin", "plexus"), "list"], env=clean_env(**daemon))


def python(prefix, source):
    packages = glob.glob(os.path.join(prefix, "lib*", "python3*", "**", "plexus", "__init__.py"), recursive=True)
    if not packages:
        print(f"SKIPPED: the Python module is not installed under {prefix} (python/ is built only when "
              "pybind11 is found; ./scripts/deps installs it)")
        return SKIP
    site = os.path.dirname(os.path.dirname(packages[0]))
    env = clean_env(PYTHONPATH=site)
    # The interpreter python/ builds the module for: Debian's, when there is one.
    interpreter = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable
    where = run([interpreter, "-c", "import plexus; print(plexus.__file__)"], env=env).strip()
    if not where.startswith(prefix):
        sys.exit(f"FAILED: import plexus found {where}, not the package under {prefix}")
    with installed_daemon(prefix) as daemon:
        env.update(daemon)
        run([interpreter, os.path.join(source, "examples", "python", "counter.py"), "3"], env=env)
    return 0


def units(prefix):
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        print("SKIPPED: systemd-analyze is not installed (Debian package systemd); units not verified")
        return SKIP
    found = sorted(glob.glob(os.path.join(prefix, "lib", "systemd", "system", "*.service")))
    if len(found) != 2:
        sys.exit(f"FAILED: expected plexusd.service and plexus-names.service, found {found}")
    # verify checks the syntax, and that ExecStart's program exists and is executable.
    run([analyze, "verify", *found])
    return 0


def main():
    step, prefix, *rest = sys.argv[1:]
    prefix = os.path.abspath(prefix)
    if step == "install":
        install(prefix, *rest)
    elif step == "cpp":
        cpp(prefix, *rest)
    elif step == "python":
        return python(prefix, *rest)
    elif step == "units":
        return units(prefix)
    elif step == "cleanup":
        shutil.rmtree(prefix, ignore_errors=True)
    else:
        sys.exit(f"unknown step {step}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
