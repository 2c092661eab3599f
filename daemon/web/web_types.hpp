#pragma once
// Threading: values.
//
// A request and a response as the endpoint's routes see them: plain values, so that only
// http_server.cpp and event_stream.cpp include Beast.

#include <string>
#include <utility>
#include <vector>

namespace plexus::daemon::web {

struct WebRequest {
    std::string path;   ///< "/api/stats"
    std::string query;  ///< "port=/a" (after '?'), "" when none
};

struct WebResponse {
    unsigned status = 200;
    std::string content_type = "application/json";
    std::string body;
    std::vector<std::pair<std::string, std::string>> headers;  ///< beyond the usual ones
};

}  // namespace plexus::daemon::web
