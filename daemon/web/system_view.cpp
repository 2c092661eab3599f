#include "system_view.hpp"

#include <set>

#include <spdlog/spdlog.h>

#include "core/wall_clock.hpp"
#include "inspect/node_view.hpp"
#include "names/name_client.hpp"
#include "net/peer.hpp"
#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"

namespace plexus::daemon::web {

namespace {
/// A daemon that takes longer than this to answer `inspect` is shown with its last part.
constexpr auto ask_timeout = std::chrono::seconds(2);

/// Keeps why `remote` could not be asked; logs it once per run of failures, not 20 times a second.
template <typename Remote>
void note_failure(Remote& remote, std::string why) {
    if (remote.error.empty())
        spdlog::warn("web: {}; the page shows its last known part", why);
    remote.error = std::move(why);
}

}  // namespace

struct SystemView::Remote {
    std::string address;
    std::string node;
    std::shared_ptr<Peer> link;
    bool link_broken = false;
    bool connecting = false;
    bool asking_part = false;
    bool asking_arbitration = false;
    nlohmann::json part;         ///< its last `inspect` answer; null before the first
    nlohmann::json arbitration;  ///< its last arbitration, from either kind of answer
    std::string error;           ///< why the last question failed; "" when it was answered
};

SystemView::SystemView(asio::any_io_executor executor, ControlHost& host, const ShmUsage& shm)
    : executor_(std::move(executor)), host_(host), shm_(shm) {}

SystemView::~SystemView() {
    close_links();
}

void SystemView::close_links() {
    for (auto& [address, remote] : remotes_) {
        if (remote->link)
            remote->link->close_when_drained();
        remote->link.reset();
    }
}

Task<nlohmann::json> SystemView::names() {
    auto reply = co_await host_.names().request(proto::ListRequest{}.encode());
    if (!reply)
        co_return nlohmann::json{{"error", reply.error().message}};
    if (reply->code != proto::ReplyCode::ok)
        co_return nlohmann::json{{"error", reply->body.value("error", std::string("refused"))}};
    auto list = proto::ListReply::decode(reply->body);
    if (!list)
        co_return nlohmann::json{{"error", list.error().message}};
    co_return list->document;
}

void SystemView::learn_daemons(const nlohmann::json& names) {
    const auto ports = names.find("ports");
    if (ports == names.end() || !ports->is_array())
        return;  // the name server did not answer: keep what we knew
    std::set<std::string> listed;
    for (const auto& port : *ports) {
        const std::string node = port.value("node", "");
        const std::string address = port.value("address", "");
        if (node.empty() || address.empty() || node == host_.config().node)
            continue;
        auto& remote = remotes_[address];
        if (!remote) {
            remote = std::make_shared<Remote>();
            remote->address = address;
        }
        remote->node = node;
        listed.insert(address);
    }
    // A daemon that went (or came back at another address) is forgotten, with its link and its
    // last part, so that the map holds no more than the daemons there are.
    std::erase_if(remotes_, [&](const auto& entry) {
        const auto& remote = *entry.second;
        if (listed.contains(entry.first) || remote.asking_part || remote.asking_arbitration ||
            remote.connecting)
            return false;
        if (remote.link)
            remote.link->close_when_drained();
        return true;
    });
}

Task<void> SystemView::ask(std::shared_ptr<Remote> remote, bool only_arbitration) {
    bool& asking = only_arbitration ? remote->asking_arbitration : remote->asking_part;
    if (asking || remote->connecting)
        co_return;
    asking = true;
    if (remote->link_broken) {
        remote->link.reset();
        remote->link_broken = false;
    }
    if (!remote->link) {
        remote->connecting = true;
        auto endpoint = proto::parse_endpoint(remote->address);
        proto::Result<std::shared_ptr<Peer>> connected = proto::Error{"bad address " + remote->address};
        if (endpoint) {
            proto::Hello hello;
            hello.role = "daemon";
            hello.node = host_.config().node;
            connected = co_await Peer::connect(executor_, *endpoint, hello, host_.config().max_frame,
                                               ask_timeout, {}, host_.config().secret);
        }
        remote->connecting = false;
        if (!connected) {
            note_failure(*remote, "cannot reach the daemon of node '" + remote->node +
                                      "': " + connected.error().message);
            asking = false;
            co_return;
        }
        remote->link = *connected;
        std::weak_ptr<Remote> weak = remote;
        remote->link->closed_handler = [weak](const std::string&) {
            if (auto alive = weak.lock())
                alive->link_broken = true;
        };
    }
    auto link = remote->link;  // the request below must keep it even if the link breaks meanwhile
    auto reply = co_await link->request(proto::InspectRequest{only_arbitration}.encode(), ask_timeout);
    asking = false;
    if (!reply || reply->code != proto::ReplyCode::ok) {
        note_failure(*remote, "the daemon of node '" + remote->node + "' did not answer: " +
                                  (!reply ? reply.error().message
                                          : reply->body.value("error", std::string("refused"))));
        remote->link_broken = true;
        co_return;
    }
    auto part = proto::InspectReply::decode(reply->body);
    if (!part || !part->document.value("arbitration", nlohmann::json()).is_array()) {
        note_failure(*remote,
                     "the daemon of node '" + remote->node + "' answered inspect with something else");
        co_return;
    }
    remote->error.clear();
    remote->arbitration = part->document["arbitration"];
    if (!only_arbitration)
        remote->part = std::move(part->document);
}

void SystemView::ask_all(bool only_arbitration) {
    for (const auto& [address, remote] : remotes_)
        asio::co_spawn(executor_, ask(remote, only_arbitration), asio::detached);
}

Task<nlohmann::json> SystemView::system(std::chrono::milliseconds wait) {
    nlohmann::json names_view = co_await names();
    learn_daemons(names_view);
    ask_all(false);
    // Wait for the answers (each question has its own timeout too); polled, as the questions
    // are independent coroutines and the wait is short.
    const auto deadline = std::chrono::steady_clock::now() + wait;
    asio::steady_timer timer(executor_);
    auto in_flight = [this] {
        return std::any_of(remotes_.begin(), remotes_.end(),
                           [](const auto& entry) { return entry.second->asking_part; });
    };
    while (in_flight() && std::chrono::steady_clock::now() < deadline) {
        timer.expires_after(std::chrono::milliseconds(10));
        co_await timer.async_wait(use_nothrow);
    }
    nlohmann::json nodes = nlohmann::json::array();
    nlohmann::json own = inspect::node_view(host_, shm_);
    own["error"] = nullptr;
    nodes.push_back(std::move(own));
    for (const auto& [address, remote] : remotes_) {
        nlohmann::json part = remote->part.is_object() ? remote->part : nlohmann::json::object();
        part["node"] = remote->node;
        part["address"] = address;
        part["error"] = remote->error.empty() ? nlohmann::json(nullptr) : nlohmann::json(remote->error);
        if (!part.contains("arbitration"))
            part["arbitration"] = nlohmann::json::array();
        nodes.push_back(std::move(part));
    }
    co_return nlohmann::json{{"t", wall_seconds()},
                             {"node", host_.config().node},
                             {"names", std::move(names_view)},
                             {"nodes", nodes}};
}

nlohmann::json SystemView::arbitration() {
    nlohmann::json ports = inspect::arbitration_view(host_)["arbitration"];
    for (const auto& [address, remote] : remotes_) {
        if (remote->arbitration.is_array()) {
            for (const auto& port : remote->arbitration)
                ports.push_back(port);
        }
    }
    ask_all(true);
    return ports;
}

}  // namespace plexus::daemon::web
