#pragma once
// Threading: the control thread (ports are opened, connected and closed there; route(), room()
// and blocked() run on the source port's thread); no locking, no sockets.

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "plexus/proto/bytes.hpp"
#include "port.hpp"

namespace plexus::daemon {

/// The ports of this daemon and the connections out of them; moves messages between them.
class Router {
public:
    /// Opens a port; refused if the name is invalid or already open here.
    proto::Result<std::shared_ptr<Port>> open(const std::string& name, std::uint64_t owner,
                                              QueuePolicy policy, std::size_t capacity,
                                              std::size_t max_bytes = ReaderQueue::default_max_bytes);
    /// Closes a port: its outgoing connections flush and go; local connections into it go.
    /// Returns every connection removed (the caller unregisters them from the name server).
    std::vector<std::shared_ptr<Connection>> close(const std::string& name);

    std::shared_ptr<Port> find(const std::string& name) const;
    const std::map<std::string, std::shared_ptr<Port>>& ports() const { return ports_; }

    /// Adds a connection out of `source`; refused if that pair is already connected.
    proto::Status add(const std::shared_ptr<Port>& source, std::shared_ptr<Connection> connection);
    /// Removes the connection source→destination; null if there was none.
    std::shared_ptr<Connection> remove(const std::string& source, const std::string& destination);
    /// Removes a specific connection object (a link that died); false if it was already gone.
    bool remove(const std::shared_ptr<Connection>& connection);

    /// True while any strict destination of `source` is full: the writer must wait.
    static bool blocked(const Port& source);
    /// How many messages the source can write before some connection out of it is full.
    static std::size_t room(const Port& source);
    /// Hands a message written into `source` to every connection out of it.
    static void route(Port& source, const Message& message);

    /// Set when the daemon runs on several threads (`--threads`): the way from a port of one thread
    /// to a sink on another, or null when the port may deliver to it directly. add() asks it.
    std::function<std::shared_ptr<MessageSink>(const Port& source, const std::shared_ptr<MessageSink>& sink)>
        crossing_for;

private:
    std::map<std::string, std::shared_ptr<Port>> ports_;
};

}  // namespace plexus::daemon
