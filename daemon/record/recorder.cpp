#include "recorder.hpp"

#include <chrono>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/batch.hpp"
#include "core/inlet.hpp"
#include "plexus/mcap/recording_layout.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon::record {

using nlohmann::json;

namespace {
std::uint64_t unix_now_ns() {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::system_clock::now().time_since_epoch())
                                          .count());
}
/// What an entry costs while it waits, besides a message's record.
constexpr std::size_t entry_overhead = 128;
/// How often an idle recording still writes what it holds.
constexpr auto flush_period = std::chrono::seconds(1);
/// How often the writer looks at the queue when nobody wakes it, and how much waiting wakes it.
constexpr auto write_period = std::chrono::milliseconds(20);
constexpr std::size_t wake_bytes = 4u << 20;
}  // namespace

struct Recorder::Entry {
    enum class Kind : std::uint8_t { connection, message, decision, event };
    Kind kind = Kind::message;
    std::uint32_t index = 0;  ///< the connection (connection, message, decision) or the watch (event)
    Message message;
    TapDecision decision;
    std::uint64_t unix_ns = 0;
    json detail;  ///< connection: its ConnectionInfo; event: the entry as written
};

struct Recorder::Connection {
    ConnectionInfo info;
    bool known = false;
};

namespace {
/// A decision as the JSON of recording_layout.hpp, written directly: a json object built and
/// dumped per message cost the writer thread more than the rest of the message. fmt's "{}" of a
/// double is its shortest exact form, so times read back bit for bit. `info.quoted_source` is the
/// source already as a JSON string.
proto::ByteView decision_text(const ConnectionInfo& info, std::uint64_t seq, const TapDecision& decision,
                              std::string& buffer) {
    buffer.clear();
    fmt::format_to(std::back_inserter(buffer),
                   R"({{"source":{},"seq":{},"outcome":"{}","monitor_time":{},"decision_time":{})",
                   info.quoted_source, seq, mcap::layout::outcome_names[static_cast<int>(decision.outcome)],
                   decision.monitor_time, decision.decision_time);
    if (decision.queue_dropped != 0)
        fmt::format_to(std::back_inserter(buffer), R"(,"queue_dropped":{})", decision.queue_dropped);
    buffer += '}';
    return {reinterpret_cast<const std::uint8_t*>(buffer.data()), buffer.size()};
}
}  // namespace

/// The tap on one recorded port, and the observer of its events.
class Recorder::Watch final : public PortTap, public arbitration::EventObserver {
public:
    Watch(Recorder& recorder, std::shared_ptr<Port> port, std::uint32_t index)
        : recorder_(recorder), port_(std::move(port)), index_(index), name_(port_->name()) {}

    const std::string& name() const { return name_; }
    const std::shared_ptr<Port>& port() const { return port_; }

    /// Registers every connection into the port now, so that the file names them all from its start.
    void note_connections() {
        for (const auto& weak : port_->inbound) {
            if (auto inlet = weak.lock())
                connection_of(*inlet);
        }
    }

    void arrived(const Inlet& inlet, const Message& message) override {
        const std::uint32_t connection = connection_of(inlet);
        if (message.shm) {
            recorder_.not_recordable(message.count());
            return;
        }
        Entry entry{Entry::Kind::message, connection, message, {}, unix_now_ns(), {}};
        recorder_.push(std::move(entry), message.record.size());
    }
    void decided(const Inlet& inlet, const Message& message, const TapDecision& decision) override {
        if (message.shm)
            return;  // counted at its arrival
        Entry entry{Entry::Kind::decision, connection_of(inlet), message, decision, unix_now_ns(), {}};
        recorder_.push(std::move(entry), 0);
    }
    void event_set(const std::string& name, const std::string& owner_label, std::optional<double> lifetime,
                   double now) override {
        json detail{{"op", "set"}, {"name", name}, {"by", owner_label}, {"time", now}};
        if (lifetime)
            detail["lifetime"] = *lifetime;
        recorder_.push(Entry{Entry::Kind::event, index_, {}, {}, unix_now_ns(), std::move(detail)}, 0);
    }
    void event_unset(const std::string& name, const std::string& owner_label) override {
        json detail{{"op", "unset"}, {"name", name}, {"by", owner_label}, {"time", recorder_.clock_.now()}};
        recorder_.push(Entry{Entry::Kind::event, index_, {}, {}, unix_now_ns(), std::move(detail)}, 0);
    }

private:
    /// The connection's index in the recording, registered at first sight. An inlet's address may
    /// be reused by a later connection: the source tells them apart.
    std::uint32_t connection_of(const Inlet& inlet) {
        if (auto found = known_.find(&inlet); found != known_.end() && found->second.source == inlet.source())
            return found->second.index;
        std::uint64_t order = 0;
        if (port_->arbiter) {
            std::lock_guard lock(port_->arbiter->mutex());
            const auto& members = port_->arbiter->members();
            for (std::size_t i = 0; i < members.size(); ++i) {
                if (members[i] == &inlet.member())
                    order = i;
            }
        }
        const std::uint32_t index = recorder_.next_connection_++;
        known_[&inlet] = {inlet.source(), index};
        json info{
            {"port", name_}, {"source", inlet.source()}, {"carrier", inlet.carrier()}, {"order", order}};
        recorder_.push(Entry{Entry::Kind::connection, index, {}, {}, 0, std::move(info)}, 0);
        return index;
    }

    struct Known {
        std::string source;
        std::uint32_t index = 0;
    };
    Recorder& recorder_;
    std::shared_ptr<Port> port_;
    std::uint32_t index_;
    std::string name_;
    std::unordered_map<const Inlet*, Known> known_;
};

Recorder::Recorder(RecorderOptions options, const arbitration::Clock& clock)
    : options_(std::move(options)), clock_(clock) {}

proto::Result<std::unique_ptr<Recorder>> Recorder::start(std::vector<std::shared_ptr<Port>> ports,
                                                         const arbitration::Clock& clock,
                                                         RecorderOptions options) {
    json names = json::array();
    json connections = json::array();
    for (const auto& port : ports) {
        if (port->tap)
            return proto::Error{"port " + port->name() + " is already being recorded"};
        names.push_back(port->name());
        // The connections at the start, with their carriers (monitors' parameters included), even
        // those that will carry nothing: a channel is only declared with its first message.
        for (const auto& weak : port->inbound) {
            if (auto inlet = weak.lock()) {
                connections.push_back({{"port", port->name()},
                                       {"source", inlet->source()},
                                       {"carrier", inlet->carrier()},
                                       {"queue", queue_policy_name(port->queue().policy())},
                                       {"capacity", port->queue().capacity()}});
            }
        }
    }
    RecordingFiles::Options file_options;
    file_options.path = options.path;
    file_options.split_bytes = options.split_bytes;
    file_options.node = options.node;
    file_options.ports = names;
    file_options.connections = connections;
    file_options.started_unix_ns = unix_now_ns();
    file_options.started_clock = clock.now();
    auto files = RecordingFiles::create(std::move(file_options));
    if (!files)
        return files.error();
    std::unique_ptr<Recorder> recorder(new Recorder(std::move(options), clock));
    recorder->files_ = std::move(*files);
    recorder->file_names_ = recorder->files_->files();
    for (auto& port : ports) {
        auto watch =
            std::make_shared<Watch>(*recorder, port, static_cast<std::uint32_t>(recorder->watches_.size()));
        recorder->watches_.push_back(watch);
        recorder->watch_names_.push_back(port->name());
        // A port without connections yet gets its arbiter now, as its first connection would: its
        // events and decisions are watched from the start.
        if (!port->arbiter)
            port->arbiter = std::make_shared<arbitration::Arbiter>(clock);
        {
            std::lock_guard lock(port->arbiter->mutex());
            port->arbiter->events().set_observer(watch.get());
        }
        port->arbiter->set_watched(true);
        port->tap = watch;
        watch->note_connections();
    }
    recorder->thread_ = std::thread([raw = recorder.get()] { raw->run(); });
    spdlog::info("recording {} into {}", names.dump(), recorder->file_names_.front());
    return recorder;
}

Recorder::~Recorder() {
    stop("the daemon let the recording go");
    if (thread_.joinable())
        thread_.join();
}

void Recorder::stop(const std::string& reason) {
    for (const auto& watch : watches_) {
        const auto& port = watch->port();
        if (port->tap.get() == watch.get())
            port->tap.reset();
        std::lock_guard lock(port->arbiter->mutex());
        port->arbiter->events().set_observer(nullptr);
        port->arbiter->set_watched(false);
    }
    watches_.clear();
    std::lock_guard lock(queue_mutex_);
    if (!stopping_) {
        stopping_ = true;
        if (reason_.empty())
            reason_ = reason;
    }
    wake_.notify_one();
}

void Recorder::not_recordable(std::uint64_t messages) {
    std::lock_guard lock(queue_mutex_);
    not_recordable_ += messages;
}

void Recorder::push(Entry entry, std::size_t bytes) {
    const std::size_t cost = bytes + entry_overhead;
    std::lock_guard lock(queue_mutex_);
    if (stopping_ || queued_bytes_ + cost > options_.backlog_bytes || ended_.load()) {
        // The disk does not keep up (or the recording ended): counted, never silently lost.
        if (entry.kind == Entry::Kind::message) {
            ++lost_in_queue_;
            lost_bytes_in_queue_ += bytes;
        } else if (entry.kind == Entry::Kind::connection) {
            queue_.push_back(std::move(entry));  // small, and later entries name it
        }
        return;
    }
    queued_bytes_ += cost;
    queue_.push_back(std::move(entry));
    // The writer is woken only once a good piece of work waits (else it looks every
    // write_period): a wake-up per message would cost the daemon's thread a futex call and the
    // writer a thread switch per message, on a machine whose cores the data path needs.
    if (queued_bytes_ >= wake_bytes && queued_bytes_ - cost < wake_bytes)
        wake_.notify_one();
}

void Recorder::run() {
    auto last_flush = std::chrono::steady_clock::now();
    for (;;) {
        std::deque<Entry> batch;
        bool stopping = false;
        {
            std::unique_lock lock(queue_mutex_);
            wake_.wait_for(lock, write_period, [&] { return queued_bytes_ >= wake_bytes || stopping_; });
            batch.swap(queue_);
            stopping = stopping_;
        }
        std::size_t written = 0;
        for (auto& entry : batch) {
            written +=
                (entry.kind == Entry::Kind::message ? entry.message.record.size() : 0) + entry_overhead;
            write(entry);
        }
        batch.clear();  // lets go of the payloads before the backlog makes room for more
        {
            std::lock_guard lock(queue_mutex_);
            queued_bytes_ -= std::min(queued_bytes_, written);
        }
        const auto now = std::chrono::steady_clock::now();
        if (now - last_flush >= flush_period) {
            files_->flush();
            last_flush = now;
        }
        note_progress(false);
        if (!ended_.load()) {
            if (!files_->error().empty())
                end(files_->error());
            else if (options_.max_bytes != 0 && files_->bytes() >= options_.max_bytes)
                end("max-bytes reached");
        }
        if (stopping) {
            std::lock_guard lock(queue_mutex_);
            if (queue_.empty())
                break;
        }
    }
    // What waits in the last chunk is written first, so that the end note counts it.
    files_->flush();
    note_progress(true);
    std::string reason;
    json end_note;
    {
        std::lock_guard queue_lock(queue_mutex_);
        std::lock_guard lock(progress_mutex_);
        reason = reason_;
        end_note = {{"messages", std::to_string(kept_)},
                    {"lost_messages", std::to_string(lost_in_queue_ + lost_in_file_)},
                    {"lost_bytes", std::to_string(lost_bytes_in_queue_ + files_->lost_bytes())},
                    {"not_recordable", std::to_string(not_recordable_)},
                    {"decisions", std::to_string(decisions_)},
                    {"events", std::to_string(events_)},
                    {"reason", reason}};
    }
    files_->close(end_note);
    note_progress(true);
    spdlog::info("recording {} closed: {} messages, {} bytes ({})", file_names_.front(), kept_, bytes_,
                 reason);
    finished_.store(true);
}

void Recorder::note_progress(bool final) {
    std::lock_guard lock(progress_mutex_);
    bytes_ = files_->bytes();
    kept_ = files_->kept_messages();
    // Messages still in the open chunk are not lost: only after a failure, or at the end, is a
    // message handed to the file but not in it lost.
    const bool settled = final || !files_->error().empty();
    lost_in_file_ = settled ? files_->handed_messages() - kept_ : 0;
    lost_bytes_in_file_ = files_->lost_bytes();
    file_names_ = files_->files();
    if (error_.empty() && !files_->error().empty())
        error_ = files_->error();
}

void Recorder::end(const std::string& reason) {
    std::lock_guard lock(queue_mutex_);
    if (reason_.empty())
        reason_ = reason;
    ended_.store(true);
    spdlog::warn("recording {} ends: {}", options_.path, reason);
}

void Recorder::write(Entry& entry) {
    switch (entry.kind) {
        case Entry::Kind::connection: {
            if (connections_.size() <= entry.index)
                connections_.resize(entry.index + 1);
            auto& connection = connections_[entry.index];
            const std::string port = entry.detail["port"];
            const std::string source = entry.detail["source"];
            connection.info = {port,
                               source,
                               entry.detail["carrier"],
                               entry.detail["order"],
                               entry.detail["source"].dump(),
                               port + '\n' + source,
                               mcap::layout::decisions_topic(port)};
            connection.known = true;
            return;
        }
        case Entry::Kind::message: {
            if (entry.index >= connections_.size())
                return;
            std::uint64_t count = 0;
            for_each_record(entry.message, [&](const Message& single) {
                const auto record = proto::read_record(single.record);
                if (!record)
                    return;
                files_->message(connections_[entry.index].info, record->seq, entry.unix_ns, record->time_ns,
                                record->payload);
                ++count;
            });
            std::lock_guard lock(progress_mutex_);
            messages_ += count;
            return;
        }
        case Entry::Kind::decision: {
            if (entry.index >= connections_.size())
                return;
            const auto& info = connections_[entry.index].info;
            std::uint64_t count = 0;
            for_each_record(entry.message, [&](const Message& single) {
                const auto record = proto::read_record(single.record);
                if (!record)
                    return;
                files_->decision(info, entry.unix_ns,
                                 decision_text(info, record->seq, entry.decision, decision_buffer_));
                ++count;
            });
            std::lock_guard lock(progress_mutex_);
            decisions_ += count;
            return;
        }
        case Entry::Kind::event: {
            files_->event(watch_names_[entry.index], entry.unix_ns, entry.detail);
            std::lock_guard lock(progress_mutex_);
            ++events_;
            return;
        }
    }
}

json Recorder::status() const {
    json out;
    {
        std::lock_guard lock(queue_mutex_);
        out["lost_messages"] = lost_in_queue_;
        out["lost_bytes"] = lost_bytes_in_queue_;
        out["not_recordable"] = not_recordable_;
        out["reason"] = reason_;
        out["waiting_bytes"] = queued_bytes_;
    }
    std::lock_guard lock(progress_mutex_);
    out["files"] = file_names_;
    out["ports"] = watch_names_;
    out["messages"] = kept_;  // in the file: a chunk still being filled is not counted yet
    out["decisions"] = decisions_;
    out["events"] = events_;
    out["bytes"] = bytes_;
    out["lost_messages"] = out["lost_messages"].get<std::uint64_t>() + lost_in_file_;
    out["lost_bytes"] = out["lost_bytes"].get<std::uint64_t>() + lost_bytes_in_file_;
    out["error"] = error_;
    out["done"] = finished_.load();
    return out;
}

}  // namespace plexus::daemon::record
