#pragma once
// Where the web endpoint's tests find the browser test and its Python (set by CMake for the
// web tests only).

#include <string>

namespace plexus::test {

/// Debian's python3, whose dist-packages hold python3-selenium and python3-prometheus-client.
inline std::string python_path() {
    return PLEXUS_PYTHON;
}
/// tests/web: page_test.py, metrics_check.py, http_get.py.
inline std::string web_tests_dir() {
    return PLEXUS_WEB_TESTS_DIR;
}
inline std::string detector_path() {
    return PLEXUS_DETECTOR_PATH;
}
/// Where a test leaves what a person looks at afterwards (the page's screenshot).
inline std::string artefacts_dir() {
    return PLEXUS_ARTEFACTS_DIR;
}

}  // namespace plexus::test
