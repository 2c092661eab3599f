# Precompiled headers. CI builds the same sources three times (normal, ASan, TSan), and most of a
# translation unit's time is parsing the same big headers again: Asio with its coroutines,
# nlohmann-json, spdlog, GoogleTest (the parse alone was 36 % of net/session.cpp's compile; with
# these headers precompiled that file compiled in 0.67 of the time). Each list below is parsed once
# per group of targets; a target of the group that reuses another's header must be built with the
# same flags, which the targets named together here are.
#
# A precompiled header makes every header of its list visible in every file of its targets, so a
# missing #include there goes unnoticed: configure with -DPLEXUS_PRECOMPILED_HEADERS=OFF to check.

# CI turns them off and builds unity builds instead (scripts/ci-build-options; docs/SANITIZERS.md:
# the CI run that first had them ran out of time, for a reason not known).
option(PLEXUS_PRECOMPILED_HEADERS "Precompile the big third-party headers (faster builds)" ON)

# The daemon's libraries above core/: Asio and its coroutines, json, spdlog.
set(PLEXUS_PCH_DAEMON
    <boost/asio.hpp>
    <boost/asio/experimental/awaitable_operators.hpp>
    <nlohmann/json.hpp>
    <spdlog/spdlog.h>
    <chrono>
    <functional>
    <map>
    <memory>
    <optional>
    <string>
    <vector>)

# The tests: GoogleTest and json (the integration harness speaks json to the daemons).
set(PLEXUS_PCH_TESTS
    <gtest/gtest.h>
    <nlohmann/json.hpp>
    <chrono>
    <filesystem>
    <fstream>
    <string>
    <thread>
    <vector>)

# The daemon's unit tests: both.
set(PLEXUS_PCH_DAEMON_TESTS ${PLEXUS_PCH_DAEMON} ${PLEXUS_PCH_TESTS})

# The command-line tool and the benchmark: json and the standard library's streams.
set(PLEXUS_PCH_TOOLS
    <nlohmann/json.hpp>
    <chrono>
    <filesystem>
    <fstream>
    <iostream>
    <string>
    <thread>
    <vector>)

# TARGET precompiles the headers of LIST (a variable's name) for itself: for its C++ files only, as
# some targets also compile C (the DDS types idlc generates come as C sources of the consumer).
function(plexus_precompile target list)
    if(PLEXUS_PRECOMPILED_HEADERS)
        set(headers "")
        foreach(header ${${list}})
            string(REGEX REPLACE "^<(.*)>$" "\\1" name "${header}")
            list(APPEND headers "$<$<COMPILE_LANGUAGE:CXX>:<${name}$<ANGLE-R>>")
        endforeach()
        target_precompile_headers(${target} PRIVATE ${headers})
    endif()
endfunction()

# TARGET uses the precompiled header FROM made (same flags; see above). Not for a target that also
# compiles C: it would look for FROM's header for C, which there is none of.
function(plexus_reuse_precompiled target from)
    if(PLEXUS_PRECOMPILED_HEADERS)
        target_precompile_headers(${target} REUSE_FROM ${from})
    endif()
endfunction()
