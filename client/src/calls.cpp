// Request/reply in libplexus (client.hpp: Port::request, Call, Service, Client::request/serve;
// PROTOCOL.md "Calls"). A call leaves as a call frame on the port's connection; its answer is
// matched by id in the connection's CallBook (call_book.hpp), which the receiving thread fills.
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <random>
#include <thread>

#include <spdlog/fmt/fmt.h>

#include "call_book.hpp"
#include "callers.hpp"
#include "connection.hpp"
#include "daemon_link.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/call.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/message.hpp"

namespace plexus {

namespace detail {

/// Builds the objects of client.hpp that only this file makes.
struct CallMaker {
    static Call call(std::shared_ptr<Connection> connection, std::uint64_t id, std::string port,
                     Received request) {
        return Call(std::move(connection), id, std::move(port), std::move(request));
    }
};

Received received_of(proto::ByteView record) {
    auto view = proto::decode_record(record);
    if (!view)
        throw Error(ErrorCode::refused, "bad message record: " + view.error().message);
    auto data = proto::decode_cbor(view->payload);
    if (!data)
        throw Error(ErrorCode::refused,
                    "bad payload from " + std::string(view->source) + ": " + data.error().message);
    return Received{{std::string(view->source), view->seq, view->time_ns}, std::move(*data)};
}

namespace {

std::uint64_t now_ns() {
    const auto now = std::chrono::system_clock::now().time_since_epoch();
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(now).count());
}

/// The Error a failed answer is: a timeout is ErrorCode::timeout, anything else refused.
Error error_of(const std::string& port, CallAnswer& answer) {
    const auto code = answer.outcome == proto::CallOutcome::timeout ? ErrorCode::timeout : ErrorCode::refused;
    return Error(code, fmt::format("call on {} {}: {}", port, proto::call_outcome_name(answer.outcome),
                                   answer.reason));
}

/// Sends `value` as a call on `port`'s connection; `done` runs once with what became of it.
void send_call(const Port& port, std::shared_ptr<Connection> connection, std::uint64_t handle,
               std::uint64_t seq, const Value& value, std::chrono::milliseconds timeout,
               std::function<void(CallAnswer)> done) {
    if (timeout.count() <= 0 || static_cast<std::uint64_t>(timeout.count()) > proto::max_call_timeout_ms)
        throw Error(ErrorCode::usage, fmt::format("a call's timeout must be 1 ms to {} ms, not {} ms",
                                                  proto::max_call_timeout_ms, timeout.count()));
    thread_local proto::Bytes payload;
    payload.clear();
    proto::encode_cbor(value, payload);
    proto::Bytes frame;
    proto::Bytes record;
    proto::append_record(record, port.name(), seq, now_ns(), payload);
    CallBook& book = connection->calls();
    // The daemon answers by the deadline; the socket is read for the answer a little longer.
    constexpr auto grace = std::chrono::seconds(2);
    const std::uint64_t id = book.add(std::move(done), CallBook::Clock::now() + timeout + grace);
    if (id == 0)
        return;  // the connection is gone: `done` was told
    proto::append_call_frame(frame, handle, id, static_cast<std::uint64_t>(timeout.count()), record);
    try {
        connection->send_frame(frame);
    } catch (const Error& e) {
        book.fail(id, proto::CallOutcome::lost, e.what());
    }
}

}  // namespace
}  // namespace detail

// --- Port ---

std::pair<std::shared_ptr<detail::Connection>, std::uint64_t> Port::current() const {
    if (!record_)
        return {nullptr, 0};
    std::lock_guard lock(record_->mutex);
    return {record_->connection, record_->handle};
}

void Port::request_then(const Value& value, std::chrono::milliseconds timeout,
                        std::function<void(Received* reply, const Error* error)> done) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    auto [connection, handle] = current();
    if (!connection)
        throw Error(ErrorCode::refused, "call on " + name_ + ": the daemon is away (reconnecting)");
    // Calls take their sequence numbers from the record (shared by every thread calling on this
    // port), not from next_seq_, which belongs to the one writing thread.
    const std::uint64_t seq = record_->call_seq.fetch_add(1, std::memory_order_relaxed) + 1;
    detail::send_call(*this, connection, handle, seq, value, timeout,
                      [done = std::move(done), port = name_](detail::CallAnswer answer) {
                          if (answer.outcome != proto::CallOutcome::ok) {
                              const Error error = detail::error_of(port, answer);
                              done(nullptr, &error);
                              return;
                          }
                          std::optional<Received> reply;
                          try {
                              reply = detail::received_of(answer.record);
                          } catch (const Error& error) {
                              done(nullptr, &error);
                              return;
                          }
                          done(&*reply, nullptr);
                      });
}

std::future<Received> Port::request_async(const Value& value, std::chrono::milliseconds timeout) {
    auto promise = std::make_shared<std::promise<Received>>();
    auto future = promise->get_future();
    request_then(value, timeout, [promise](Received* reply, const Error* error) {
        if (reply)
            promise->set_value(std::move(*reply));
        else
            promise->set_exception(std::make_exception_ptr(*error));
    });
    return future;
}

namespace {

/// The answer to one blocking call: filled by whichever thread completes the call (the receiving
/// thread, most often), turned into a value or an Error on the caller's. Not a future: an
/// exception made on the receiving thread and thrown on the caller's is freed by whichever lets go
/// of it last, through a reference count ThreadSanitizer cannot see (libsupc++'s), and with it the
/// string std::runtime_error shares; here every byte is handed over under a mutex.
struct BlockingAnswer {
    std::mutex mutex;
    std::condition_variable done;
    bool answered = false;
    std::optional<Received> reply;
    ErrorCode code = ErrorCode::refused;
    std::string reason;
};

std::function<void(Received*, const Error*)> answer_into(std::shared_ptr<BlockingAnswer> answer) {
    return [answer = std::move(answer)](Received* reply, const Error* error) {
        {
            std::lock_guard lock(answer->mutex);
            if (reply) {
                answer->reply = std::move(*reply);
            } else {
                answer->code = error->code();
                answer->reason = error->what();
            }
            answer->answered = true;
        }
        answer->done.notify_all();
    };
}

/// Waits for the answer; the daemon answers by the call's deadline (its own timeout), or the
/// connection's loss does: `guard` more is only a last bound against a daemon that stopped
/// answering without going away.
Received wait_for_answer(BlockingAnswer& answer, std::chrono::milliseconds timeout, const std::string& what) {
    constexpr auto guard = std::chrono::seconds(2);
    std::unique_lock lock(answer.mutex);
    if (!answer.done.wait_for(lock, timeout + guard, [&] { return answer.answered; }))
        throw Error(ErrorCode::timeout, fmt::format("{}: no answer within {} ms", what, timeout.count()));
    if (answer.reply)
        return std::move(*answer.reply);
    throw Error(answer.code, answer.reason);
}

}  // namespace

Received Port::request(const Value& value, std::chrono::milliseconds timeout) {
    auto answer = std::make_shared<BlockingAnswer>();
    request_then(value, timeout, answer_into(answer));
    return wait_for_answer(*answer, timeout, "call on " + name_);
}

// --- Call ---

Call::Call(std::shared_ptr<detail::Connection> connection, std::uint64_t id, std::string port,
           Received request)
    : connection_(std::move(connection)), id_(id), port_(std::move(port)), request_(std::move(request)) {}

Call::Call(Call&& other) noexcept
    : connection_(std::move(other.connection_)),
      answered_(std::exchange(other.answered_, true)),
      id_(other.id_),
      port_(std::move(other.port_)),
      request_(std::move(other.request_)) {}

Call& Call::operator=(Call&& other) noexcept {
    if (this != &other) {
        if (!answered_) {
            try {
                fail("the call was dropped unanswered (replaced by another)");
            } catch (...) {
            }
        }
        connection_ = std::move(other.connection_);
        answered_ = std::exchange(other.answered_, true);
        id_ = other.id_;
        port_ = std::move(other.port_);
        request_ = std::move(other.request_);
    }
    return *this;
}

Call::~Call() {
    if (answered_)
        return;
    try {
        fail("the server's handler returned without answering");
    } catch (...) {
        // The connection is gone: the daemon fails the call itself.
    }
}

void Call::send(const std::vector<std::uint8_t>& frame) {
    if (answered_)
        throw Error(ErrorCode::usage, "the call on " + port_ + " was already answered");
    answered_ = true;
    connection_->send_frame(frame);
}

void Call::reply(const Value& value) {
    proto::Bytes payload;
    proto::encode_cbor(value, payload);
    proto::Bytes record;
    proto::append_record(record, port_, request_.envelope.seq, detail::now_ns(), payload);
    proto::Bytes frame;
    proto::append_answer_frame(frame, id_, record);
    send(frame);
}

void Call::fail(const std::string& reason) {
    proto::Bytes frame;
    proto::append_failed_answer_frame(frame, id_, proto::CallOutcome::failed, reason);
    send(frame);
}

// --- Service ---

struct Service::State {
    Port port;
    std::function<void(Call)> handler;
    std::atomic<std::uint64_t> calls{0};
    std::jthread thread;

    State(Port opened, std::function<void(Call)> handle)
        : port(std::move(opened)), handler(std::move(handle)) {}

    /// The Service's thread: takes the calls of its port from whichever connection it lives on now.
    void run(std::stop_token stop) {
        std::deque<detail::IncomingCall> taken;
        while (!stop.stop_requested()) {
            auto [connection, handle] = port.current();
            if (!connection) {
                std::this_thread::sleep_for(std::chrono::milliseconds(50));  // the daemon is away
                continue;
            }
            const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
            if (!connection->calls().take(handle, deadline, taken))
                continue;
            for (auto& incoming : taken) {
                ++calls;
                Received request;
                try {
                    request = detail::received_of(incoming.record);
                } catch (const Error& e) {
                    detail::CallMaker::call(connection, incoming.id, port.name(), {}).fail(e.what());
                    continue;
                }
                auto call = detail::CallMaker::call(connection, incoming.id, port.name(), std::move(request));
                try {
                    handler(std::move(call));
                } catch (...) {
                    // serve_calls' handler owns the Call once called; an exception there is its own.
                }
            }
            taken.clear();
        }
    }
};

Service::Service(std::unique_ptr<State> state) : state_(std::move(state)) {
    State* raw = state_.get();
    raw->thread = std::jthread([raw](std::stop_token stop) { raw->run(stop); });
}

Service::Service(Service&& other) noexcept = default;

Service::~Service() {
    if (!state_)
        return;
    state_->thread.request_stop();
    if (state_->thread.joinable())
        state_->thread.join();
    auto [connection, handle] = state_->port.current();
    if (connection)
        connection->calls().stop(handle);
}

const std::string& Service::port() const {
    return state_->port.name();
}

std::uint64_t Service::calls() const {
    return state_->calls.load();
}

// --- Client ---

Port& Client::caller_for(const std::string& target) {
    if (!callers_)
        throw Error(ErrorCode::usage, "this client was moved from");
    std::lock_guard lock(callers_->mutex);
    auto& port = callers_->by_target[target];
    if (port)
        return *port;
    // A name no other client picks: random, as a port name must be unique in the whole system.
    std::random_device seed;
    const std::string name = fmt::format("/plexus/call/{:016x}", (std::uint64_t{seed()} << 32) | seed());
    auto opened = std::make_unique<Port>(open(name));
    try {
        connect(name, target);
    } catch (...) {
        callers_->by_target.erase(target);
        throw;
    }
    port = std::move(opened);
    return *port;
}

Received Client::request(const std::string& port, const Value& value, std::chrono::milliseconds timeout) {
    auto answer = std::make_shared<BlockingAnswer>();
    request_then(port, value, timeout, answer_into(answer));
    return wait_for_answer(*answer, timeout, "call to " + port);
}

std::future<Received> Client::request_async(const std::string& port, const Value& value,
                                            std::chrono::milliseconds timeout) {
    auto promise = std::make_shared<std::promise<Received>>();
    auto future = promise->get_future();
    request_then(port, value, timeout, [promise](Received* reply, const Error* error) {
        if (reply)
            promise->set_value(std::move(*reply));
        else
            promise->set_exception(std::make_exception_ptr(*error));
    });
    return future;
}

void Client::request_then(const std::string& port, const Value& value, std::chrono::milliseconds timeout,
                          std::function<void(Received* reply, const Error* error)> done) {
    Port& caller = caller_for(port);
    // Errors name the port called, not the port of this client's own that called it.
    caller.request_then(value, timeout,
                        [done = std::move(done), from = "call on " + caller.name(), to = "call to " + port](
                            Received* reply, const Error* error) {
                            if (!error || std::string_view(error->what()).rfind(from, 0) != 0)
                                return done(reply, error);
                            const Error renamed(error->code(), to + (error->what() + from.size()));
                            done(nullptr, &renamed);
                        });
}

Service Client::serve_calls(const std::string& port, std::function<void(Call)> handler) {
    PortOptions options;
    options.serve = true;
    // Its queue holds as many calls as the daemon lets be outstanding on one port: a burst of
    // calls waits for the handler rather than being refused as busy by a full queue first.
    options.capacity = 4096;
    return Service(std::make_unique<Service::State>(open(port, options), std::move(handler)));
}

Service Client::serve(const std::string& port, std::function<Value(const Received&)> handler) {
    return serve_calls(port, [handler = std::move(handler)](Call call) {
        try {
            call.reply(handler(call.request()));
        } catch (const std::exception& e) {
            if (!call.answered())
                call.fail(std::string("the handler threw: ") + e.what());
        } catch (...) {
            if (!call.answered())
                call.fail("the handler threw something that is not a std::exception");
        }
    });
}

}  // namespace plexus
