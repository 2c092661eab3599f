#pragma once
// What every fuzz target shares: a property that fails must stop the fuzzer with a crash (so
// libFuzzer saves the input), and say which property it was.

#include <cstdio>
#include <cstdlib>

/// Aborts with the property's text and place when `condition` is false; kept in Release builds,
/// unlike assert().
#define PLEXUS_FUZZ_CHECK(condition)                                                              \
    do {                                                                                          \
        if (!(condition)) {                                                                       \
            std::fprintf(stderr, "%s:%d: property failed: %s\n", __FILE__, __LINE__, #condition); \
            std::abort();                                                                         \
        }                                                                                         \
    } while (false)
