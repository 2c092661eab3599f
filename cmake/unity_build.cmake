# Unity builds: each target's sources compiled in batches, one translation unit per batch. Most of
# a file's compile here is not its own code but the instantiation and optimisation of the same
# templates (Asio's coroutines, json, spdlog) that every file of a target instantiates again; a
# batch does that once. Four files of daemon/control/ under ASan: 162 s one by one, 64 s as one
# unit. CI builds the sources three times and turns this on (scripts/test, scripts/sanitize);
# off by default because touching one file recompiles its whole batch.
#
# A batch puts files side by side in one unit: two files of a target cannot both define the same
# name in an anonymous namespace or as a static function. Keep such helpers named after their file
# or in a named namespace (each integration test file's code is in a namespace named after the
# file); a build with -DPLEXUS_UNITY_BUILD=ON finds a clash at once.

option(PLEXUS_UNITY_BUILD "Compile each target's sources in batches (faster full builds, slower edits)" OFF)
if(PLEXUS_UNITY_BUILD)
    set(CMAKE_UNITY_BUILD ON)
    set(CMAKE_UNITY_BUILD_BATCH_SIZE 8)
endif()
