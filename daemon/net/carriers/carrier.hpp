#pragma once
// Threading: the daemon's one thread (the control plane calls carriers from its request handlers).
//
// A carrier is how a connection's messages travel from its source port to its destination: `tcp`,
// `udp`, `mcast` between daemons, `local` inside one. The control plane knows none of them by
// name: it parses the carrier text, looks its base up in the table (carrier_table.hpp) and lets
// the entry make the sending end and attach the receiving end. A new carrier (a recording tap, a
// bridge, a request/reply path) is a class here and a row there. YARP's `Carrier` is the model;
// unlike YARP's, a carrier here is stateless (one const object per kind, like the control plane's
// op table): what lives on between connections belongs to the daemon and is reached through
// CarrierHost (the UDP socket, the mcast senders found through it).

#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "../../core/connection.hpp"
#include "../../core/inlet.hpp"
#include "../../core/reader_queue.hpp"
#include "../asio.hpp"
#include "../net_config.hpp"
#include "../peer.hpp"
#include "../session.hpp"
#include "../udp_socket.hpp"
#include "plexus/proto/carrier.hpp"
#include "plexus/proto/endpoint.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::daemon::carriers {

/// What a carrier needs of the daemon, and nothing more: net/ does not include control/ or names/
/// (the daemon implements it, through ControlHost).
class CarrierHost {
public:
    virtual const NetConfig& config() const = 0;
    /// The daemon's UDP socket, which udp and mcast send and receive on.
    virtual UdpSocket& udp() = 0;
    /// The multicast group ("A.B.C.D:PORT") the name server gives `source`: the one both ends of
    /// an mcast connection must agree on, vouched for by the name server rather than the sender.
    virtual Task<proto::Result<std::string>> mcast_group(std::string source) = 0;

protected:
    ~CarrierHost() = default;
};

/// Puts the connection's send-side monitors on a stage of their own that reports to `client`, and
/// returns it; null when the connection has none. `drop_oldest`: the stage drops its oldest
/// waiting message when the monitors fall behind, for a sending end that never holds the writer
/// back. Made by the control plane (it owns the scripts); a carrier only chooses the client.
using SendStageMaker =
    std::function<std::shared_ptr<MessageFilter>(std::weak_ptr<FilterClient> client, bool drop_oldest)>;

/// What a carrier makes its sending end from. Across daemons the link is open and the receiving
/// daemon has answered `attach`; inside one (`local`) the destination's inlet is wired.
struct SendingContext {
    CarrierHost& host;
    proto::AttachRequest request;  ///< source, destination, carrier text, and what prepare_attach added
    proto::Carrier carrier;        ///< the carrier parsed (qos); empty base for a local connect naming none
    std::shared_ptr<Peer> link;    ///< across daemons: the link that attached the connection
    proto::Endpoint endpoint;      ///< across daemons: where the receiving daemon listens
    proto::AttachReply attached;   ///< across daemons: its answer to attach
    std::shared_ptr<Inlet> inlet;  ///< local: the destination's new inlet
    std::shared_ptr<Connection> connection;  ///< the connection being made (its sink not set yet)
    SendStageMaker make_send_stage;
};

/// A carrier's sending end: what the connection hands its messages to.
struct SendingEnd {
    std::shared_ptr<MessageSink> sink;
    /// The connection's own send-side monitors, in front of the sink; null when it has none or
    /// when the sink runs the port's shared ones (MessageSink::shared_send_stage).
    std::shared_ptr<MessageFilter> send_monitors;
    /// What waits in the sending end to leave, counted as lost if the link dies; null if nothing waits.
    std::shared_ptr<const ReaderQueue> queue;
};

/// What a carrier attaches the receiving end of a connection from another daemon to: the link
/// session that asked, and the inlet wired for it into the destination port.
struct ReceivingContext {
    CarrierHost& host;
    std::shared_ptr<Session> session;
    proto::AttachRequest request;
    proto::Carrier carrier;
    std::shared_ptr<Inlet> inlet;
};

/// One kind of carrier: an entry of the carrier table.
class Carrier {
public:
    virtual ~Carrier() = default;

    /// The base name carrier strings start with ("tcp").
    virtual std::string_view name() const = 0;
    /// True when both ports must be on this daemon (`local`): no link, no attach. False for a
    /// carrier between daemons, used even between ports of one daemon when named (over loopback).
    virtual bool within_daemon() const { return false; }
    /// Before the link asks the receiving daemon to attach: what this carrier's attach request
    /// carries beyond the common fields (mcast: the source port's group). An Error refuses the
    /// connection before any link is opened. As it came by default.
    virtual Task<proto::Result<proto::AttachRequest>> prepare_attach(CarrierHost& host,
                                                                     proto::AttachRequest request) const;
    /// The sending end of a connection, and where its send-side monitors run. An Error refuses the
    /// connection; the caller closes the link.
    virtual proto::Result<SendingEnd> make_sending_end(const SendingContext& context) const = 0;
    /// The receiving end, while this daemon answers `attach`: what feeds the inlet besides the link
    /// session's data frames (udp: a datagram stream, mcast: the joined group), and what the answer
    /// tells the sending daemon about it. An Error refuses the attach. By default the link session
    /// alone feeds the inlet, and the answer goes as it came.
    virtual Task<proto::Result<proto::AttachReply>> attach_receiving_end(ReceivingContext context,
                                                                         proto::AttachReply answer) const;
};

/// The send-side monitors of a connection that runs its own, in front of `sink`: a sink that never
/// holds the writer back (latest, datagrams) makes them drop their oldest waiting message when
/// they fall behind, rather than hold it back.
std::shared_ptr<MessageFilter> own_send_monitors(const SendingContext& context, const MessageSink& sink);

}  // namespace plexus::daemon::carriers
