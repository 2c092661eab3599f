#pragma once
// Threading: plain file I/O, no shared state; the name server calls it from its one thread.
//
// The name server's state file: the persistent connections, as JSON. It is written durably
// (a temporary file, fsync'd, renamed over the old one, then the directory fsync'd), so after a
// power cut the file is the old one or the new one, whole. A file that cannot be read all the
// same (emptied or cut short by a disk that lied, edited by hand) does not stop the name server:
// it starts with what it can read and says what it could not.

#include <string>
#include <vector>

#include "plexus/proto/bytes.hpp"
#include "registry.hpp"

namespace plexus::daemon::names {

/// What read_state found.
struct StateRead {
    std::vector<ConnectionEntry> persistent;  ///< the entries that could be read
    std::vector<std::string> problems;        ///< one line each, naming the file; empty when all was read
};

/// Reads the state file at `path`. A missing file is an empty state, not a problem.
StateRead read_state(const std::string& path);

/// The state file's text for `persistent`.
std::string state_text(const std::vector<ConnectionEntry>& persistent);

/// Replaces the file at `path` with `text` durably (see above); an Error says which step failed.
proto::Status write_durably(const std::string& path, const std::string& text);

}  // namespace plexus::daemon::names
