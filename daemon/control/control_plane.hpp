#pragma once
// Threading: the daemon's one thread.

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "control_host.hpp"
#include "names/name_protocol.hpp"
#include "net/asio.hpp"
#include "net/carriers/carrier.hpp"
#include "net/permission_gate.hpp"
#include "net/shm_region.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/endpoint.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/proto/ops.hpp"
#include "record/recorder.hpp"

namespace plexus::daemon {

struct Connection;
class MessageSink;
class Peer;
class ReaderQueue;
class Session;
namespace monitor {
struct MonitorChain;
}

/// The daemon's answers to control requests (PROTOCOL.md, "Control operations"): a table from op
/// name to handler, each with the session roles that may send it. Handlers live in files by
/// subject: ports.cpp, connections.cpp, param.cpp, forward.cpp, views.cpp.
class ControlPlane {
public:
    ControlPlane(asio::any_io_executor executor, ControlHost& host);
    ~ControlPlane();  ///< stops the recordings and waits for their files to close

    /// Answers one request of `session`. An op the session's role may not send is answered as
    /// an unknown one.
    Task<proto::Reply> handle(std::shared_ptr<Session> session, proto::Request request);
    /// Makes the remembered connections of a port that just registered.
    Task<void> restore_persistent(std::vector<names::ConnectionEntry> persistent);
    /// The shared-memory regions handed out so far (the stats view counts them).
    const ShmUsage& shm_usage() const { return *shm_usage_; }
    /// The --permissions checks (SIGHUP reloads their file).
    PermissionGate& permissions() { return permissions_; }

private:
    /// Every handler has this shape, whether or not it looks at the session. Coroutines must be
    /// member (or free) functions: g++ 12 miscompiles capturing lambdas used as coroutines.
    using Handler = Task<proto::Reply> (ControlPlane::*)(std::shared_ptr<Session> session,
                                                         const proto::Request& request);
    /// Which sessions may send an op, by the role their hello gave.
    enum class Callers { any, client, link };
    struct Operation {
        proto::Op op;
        Callers callers;
        Handler handler;
    };
    /// The table (control_plane.cpp). To add an op: write its handler, add a row, list it in
    /// PROTOCOL.md.
    static const Operation operations_[];
    /// The row of `op` if a session whose hello said `role` may send it; else null.
    static const Operation* find_operation(proto::Op op, const std::string& role);

    /// The link of a connection to another daemon, once that daemon has attached its end.
    struct AttachedLink {
        std::shared_ptr<Peer> peer;    ///< the link to the receiving daemon; null if refused
        proto::AttachRequest request;  ///< what it was asked, with what the carrier added
        proto::Reply answer;           ///< the receiving daemon's answer to attach, or why there is no link
        proto::AttachReply attached;   ///< that answer decoded, when it was one
    };

    // ports.cpp: a client's own ports.
    Task<proto::Reply> open_port(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> close_port(std::shared_ptr<Session> session, const proto::Request& request);
    /// `shm`: the client maps shared-memory regions; with a handle, it gets one for that port.
    Task<proto::Reply> shm(std::shared_ptr<Session> session, const proto::Request& request);

    // connections.cpp
    /// Needs no session: restore_persistent calls it with none.
    Task<proto::Reply> connect(std::shared_ptr<Session> session, const proto::Request& request);
    /// The connection to another daemon (`address`, node `node`) with carrier `carrier` (its text,
    /// and its entry in the carrier table, `chosen`), and its route constraint (carrier_rules.hpp).
    Task<proto::Reply> connect_remote(proto::ConnectRequest asked, std::shared_ptr<Port> source,
                                      std::string carrier, const carriers::Carrier* chosen,
                                      std::string address, std::string node,
                                      std::shared_ptr<monitor::MonitorChain> send_chain,
                                      std::optional<arbitration::Constraint> route);
    /// Connects to the daemon of node `node` at `endpoint` and asks it to attach `destination` for
    /// this connection, with what carrier `chosen` adds to the request. The carrier then makes the
    /// sending end on this link (connect_remote).
    Task<AttachedLink> open_link(std::shared_ptr<Port> source, const carriers::Carrier* chosen,
                                 std::string destination, std::string carrier, proto::Endpoint endpoint,
                                 std::string node, bool strict);
    /// What makes the stage of a connection's send-side monitors, for its carrier to call (null
    /// without monitors). The control plane owns the scripts; the carrier chooses where they report.
    carriers::SendStageMaker send_stage_maker(std::shared_ptr<monitor::MonitorChain> chain);
    /// When `link` closes: counts what its `queue` could not send, removes the connection, and
    /// makes a persistent one again (remake_persistent).
    void watch_link(std::shared_ptr<Peer> link, std::shared_ptr<const ReaderQueue> queue,
                    const std::shared_ptr<Connection>& connection);
    /// The receiving end of a connection from another daemon: the link session feeds an inlet.
    Task<proto::Reply> attach(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> disconnect(std::shared_ptr<Session> session, const proto::Request& request);
    /// A persistent connection whose link broke while both ends live (a reset, a cable, bytes
    /// altered on the path): tries to make it again, backing off from 100 ms to 5 s, until it is
    /// made, its source closes, its destination is no longer registered (its return restores it,
    /// restore_persistent), it is disconnected, or the daemon stops.
    Task<void> remake_persistent(names::ConnectionEntry entry);

    // param.cpp
    Task<proto::Reply> param(std::shared_ptr<Session> session, const proto::Request& request);
    /// The recv half of `plexus param`: the monitors of the inlet source -> destination here.
    Task<proto::Reply> param_recv(std::shared_ptr<Session> session, const proto::Request& request);

    // forward.cpp: questions about this daemon, or for another one or the name server.
    Task<proto::Reply> ping(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> node(std::shared_ptr<Session> session, const proto::Request& request);
    /// `lookup`: asked of the name server, its answer relayed.
    Task<proto::Reply> lookup(std::shared_ptr<Session> session, const proto::Request& request);
    /// `list`: asked of the name server, its answer relayed.
    Task<proto::Reply> list(std::shared_ptr<Session> session, const proto::Request& request);
    /// Sends the request to the daemon that hosts `port`, marked forwarded, and relays its reply;
    /// refuses one that was `forwarded` here already. The body goes on as it came, with any field
    /// this daemon does not know: the daemon that answers may.
    Task<proto::Reply> forward(const proto::Request& request, bool forwarded, const std::string& port);

    // views.cpp: the views of inspect/, for this daemon's ports, or asked of the one hosting them.
    Task<proto::Reply> stats(std::shared_ptr<Session> session, const proto::Request& request);
    /// `plexus events PORT`: the port's event container and arbitration state.
    Task<proto::Reply> events(std::shared_ptr<Session> session, const proto::Request& request);
    /// This daemon's part of the whole system's view, for a web endpoint (never forwarded).
    Task<proto::Reply> inspect(std::shared_ptr<Session> session, const proto::Request& request);

    // record.cpp: recordings of this daemon's ports (docs/RECORDING.md).
    Task<proto::Reply> record_start(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> record_status(std::shared_ptr<Session> session, const proto::Request& request);
    Task<proto::Reply> record_stop(std::shared_ptr<Session> session, const proto::Request& request);
    /// A client's own counters for one of its ports (a bridge's drops), kept for `stats`.
    Task<proto::Reply> report(std::shared_ptr<Session> session, const proto::Request& request);
    /// Stops recordings whose client went away or that cannot go on; runs while there are some.
    Task<void> sweep_recordings(std::weak_ptr<void> alive);
    struct Recording {
        std::weak_ptr<Session> owner;  ///< the session that asked: the recording ends with it
        std::unique_ptr<record::Recorder> recorder;
        bool stopped = false;
        /// For a recording another daemon asked for: the last time it asked (see record.cpp).
        std::optional<std::chrono::steady_clock::time_point> lease;
    };

    // GCC 12 miscompiles braced temporaries and lambdas inside co_await expressions: build them
    // in these plain functions instead.
    proto::Hello our_hello(const char* role) const;
    std::function<void()> space_notifier();

    // permissions.cpp: the permissions file's checks (core/permissions.hpp), at connect time.
    /// Ok when `who` may do `action` on `port`; else the refusal, counted (stats) and logged once.
    proto::Status permitted(const Principal& who, Action action, std::string_view port);
    /// The same for what `asker` asks (nothing to check without one: the daemon's own requests,
    /// remaking persistent connections, were checked when first made).
    proto::Status permitted(const Session* asker, Action action, std::string_view port);
    /// What a connection with `carrier` from `source` to `destination` needs of the one who asks
    /// at the source's daemon: connect on the source, monitor on the ports its monitors run on
    /// (send clauses: the source; recv: the destination), write on a destination of this daemon.
    proto::Status connect_permitted(const Session* asker, const proto::Carrier& carrier,
                                    const std::string& source, const std::string& destination,
                                    bool local_destination);

    /// How long a connect to another daemon, and a request on it, may take.
    static constexpr auto peer_timeout = std::chrono::seconds(5);

    asio::any_io_executor executor_;
    ControlHost& host_;
    PermissionGate permissions_;
    std::shared_ptr<ShmUsage> shm_usage_ = std::make_shared<ShmUsage>();
    std::uint64_t next_region_ = 1;
    std::map<std::uint64_t, Recording> recordings_;
    std::uint64_t next_recording_ = 1;
    /// "SOURCE -> DESTINATION" of the persistent connections remake_persistent is making again.
    std::set<std::string> remaking_;
    /// Expires with the control plane: a sweep that wakes after it knows not to touch it.
    std::shared_ptr<void> alive_ = std::make_shared<int>(0);
};

}  // namespace plexus::daemon
