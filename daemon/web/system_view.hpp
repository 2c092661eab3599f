#pragma once
// Threading: the daemon's one thread.
//
// The whole system as the web endpoint shows it (docs/WEB.md, `/api/system`): this daemon's part
// built here, every other daemon's asked over an authenticated link with the `inspect` op. The
// daemons are those the name server lists ports for. Each link is kept open while someone
// watches, so the stream can ask for the arbitration 20 times a second without a handshake each.

#include <chrono>
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "control/control_host.hpp"
#include "net/asio.hpp"
#include "net/shm_region.hpp"

namespace plexus::daemon::web {

class SystemView {
public:
    SystemView(asio::any_io_executor executor, ControlHost& host, const ShmUsage& shm);
    ~SystemView();

    /// The name server's list, or `{"error": why}`.
    Task<nlohmann::json> names();
    /// The whole system: every daemon's part, the others' asked now and waited for at most `wait`
    /// (a daemon that did not answer in time shows its last part, or its error).
    Task<nlohmann::json> system(std::chrono::milliseconds wait);
    /// The events documents of every arbitrated port of every daemon: this one's now, the others'
    /// as last heard; asks them again (without waiting) for the next call.
    nlohmann::json arbitration();
    /// Closes the links to other daemons (nobody watches any more, or the daemon stops).
    void close_links();

private:
    struct Remote;
    /// Learns the other daemons from the name server's list (`names`).
    void learn_daemons(const nlohmann::json& names);
    /// Asks `remote` for its part (or only its arbitration), unless such a question is on its way.
    Task<void> ask(std::shared_ptr<Remote> remote, bool only_arbitration);
    void ask_all(bool only_arbitration);

    asio::any_io_executor executor_;
    ControlHost& host_;
    const ShmUsage& shm_;
    std::map<std::string, std::shared_ptr<Remote>> remotes_;  ///< by address
};

}  // namespace plexus::daemon::web
