#pragma once
// Threading: constant data.
//
// The web page's files (tools/web/page/), built into plexusd: the page works wherever the daemon
// runs, installed or not, and offline; nothing is read from disk at run time. The table is made
// at build time (daemon/web/CMakeLists.txt).

#include <string_view>

namespace plexus::daemon::web {

struct PageFile {
    std::string_view path;          ///< as served: "/static/app.js"
    std::string_view content_type;  ///< "text/javascript; charset=utf-8"
    std::string_view bytes;
};

/// The file served at `path`, or null.
const PageFile* find_page_file(std::string_view path);

}  // namespace plexus::daemon::web
