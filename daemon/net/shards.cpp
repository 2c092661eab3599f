#include "shards.hpp"

#include <spdlog/spdlog.h>

#include "shard_crossing.hpp"

namespace plexus::daemon {

Shard::Shard(std::size_t number, asio::io_context* control)
    : number_(number),
      own_io_(control ? nullptr : std::make_unique<asio::io_context>(1)),
      io_(control ? control : own_io_.get()),
      space_(io_->get_executor()) {}

Shard::~Shard() {
    stop();
}

void Shard::post(std::function<void()> work) {
    std::lock_guard lock(mutex_);
    if (!stopped_ && io_)
        asio::post(*io_, std::move(work));
}

void Shard::send(std::shared_ptr<ShardCrossing> crossing, Message message, bool close) {
    std::lock_guard lock(mutex_);
    if (stopped_)
        return;
    mail_.push_back(Mail{std::move(crossing), std::move(message), close});
    schedule_locked();
}

void Shard::want_room(std::shared_ptr<ShardCrossing> crossing) {
    std::lock_guard lock(mutex_);
    if (stopped_)
        return;
    room_wanted_.push_back(std::move(crossing));
    any_room_wanted_.store(true, std::memory_order_release);
    schedule_locked();
}

void Shard::hold(std::shared_ptr<ShardCrossing> crossing) {
    holding_.push_back(std::move(crossing));
    any_holding_.store(true, std::memory_order_release);
}

void Shard::release_held() {
    if (holding_.empty())
        return;
    std::erase_if(holding_, [](const auto& crossing) { return !crossing->release_held(); });
    any_holding_.store(!holding_.empty(), std::memory_order_release);
}

void Shard::schedule_locked() {
    if (scheduled_)
        return;
    scheduled_ = true;
    asio::post(*io_, [self = shared_from_this()] { self->read_mail(); });
}

void Shard::read_mail() {
    {
        std::lock_guard lock(mutex_);
        reading_.swap(mail_);
        scheduled_ = false;
    }
    for (auto& mail : reading_) {
        if (mail.close)
            mail.crossing->arrive_close();
        else
            mail.crossing->arrive(mail.message);
    }
    reading_.clear();
    answer_room_requests();
}

void Shard::answer_room_requests() {
    if (!any_room_wanted_.load(std::memory_order_acquire))
        return;
    std::vector<std::shared_ptr<ShardCrossing>> asking;
    {
        std::lock_guard lock(mutex_);
        asking.swap(room_wanted_);
        any_room_wanted_.store(false, std::memory_order_relaxed);
    }
    std::vector<std::shared_ptr<ShardCrossing>> still;
    for (auto& crossing : asking) {
        if (crossing->refresh_room() > 0)
            crossing->wake_source();
        else
            still.push_back(std::move(crossing));
    }
    if (still.empty())
        return;
    std::lock_guard lock(mutex_);
    room_wanted_.insert(room_wanted_.end(), std::make_move_iterator(still.begin()),
                        std::make_move_iterator(still.end()));
    any_room_wanted_.store(true, std::memory_order_release);
}

Task<bool> Shard::wait_for_space(std::chrono::steady_clock::duration timeout) {
    co_return co_await space_.wait_for(timeout);
}

void Shard::space_appeared() {
    release_held();  // first: what waited longest goes in before writers woken now
    space_.notify();
    answer_room_requests();
}

void Shard::poke() {
    // The room published before this call, against expect_space(): see there.
    std::atomic_thread_fence(std::memory_order_seq_cst);
    // Read first: a drain on every thread would otherwise write this line on every call.
    const bool writers = writers_waiting_.load(std::memory_order_acquire) &&
                         writers_waiting_.exchange(false, std::memory_order_acq_rel);
    // Crossings that hold messages or wait for room here are looked at again too: the port closed
    // may be their sink's (ShardCrossing::release_held, refresh_room).
    if (writers || any_holding_.load(std::memory_order_acquire) ||
        any_room_wanted_.load(std::memory_order_acquire))
        post([self = shared_from_this(), writers] {
            self->release_held();
            if (writers)
                self->space_.notify();
            self->answer_room_requests();
        });
}

void Shard::start(ShardGates& gates) {
    role_ = ThreadRole{&gates, number_, 0};
    work_ = std::make_unique<asio::executor_work_guard<asio::io_context::executor_type>>(io_->get_executor());
    thread_ = std::thread([this] {
        this_thread_role = &role_;
        io_->run();
        this_thread_role = nullptr;
    });
}

void Shard::stop() {
    halt();
    dispose();
}

void Shard::halt() {
    {
        std::lock_guard lock(mutex_);
        stopped_ = true;
        mail_.clear();
        room_wanted_.clear();
    }
    if (thread_.joinable()) {
        work_.reset();
        io_->stop();
        thread_.join();
    }
    holding_.clear();  // a crossing holds its shards: a cycle otherwise
}

void Shard::dispose() {
    if (!own_io_)
        return;
    // Coroutines parked on a Signal of this thread (sessions' loops) hold what they wait for:
    // destroyed now, as the control thread's are (Daemon::run), and then whatever else its
    // io_context holds, while the daemon they refer to still exists.
    asio::use_service<SignalService>(*io_).destroy_parked();
    own_io_.reset();
    io_ = nullptr;
}

Shards::Shards(asio::io_context& control, std::size_t threads) : gates_(threads > 1 ? threads : 0) {
    shards_.push_back(std::make_shared<Shard>(0, &control));
    for (std::size_t n = 1; threads > 1 && n <= threads; ++n)
        shards_.push_back(std::make_shared<Shard>(n, nullptr));
}

Shards::~Shards() {
    stop();
}

namespace {
/// The control thread's role: set while it runs the daemon.
ThreadRole control_role;
}  // namespace

void Shards::start() {
    if (started_ || data_threads() == 0)
        return;
    started_ = true;
    control_role = ThreadRole{&gates_, 0, 0};
    this_thread_role = &control_role;
    for (std::size_t n = 1; n < shards_.size(); ++n)
        shards_[n]->start(gates_);
    spdlog::info("{} data threads beside the control thread", data_threads());
}

void Shards::stop() {
    if (!started_)
        return;
    started_ = false;
    // The control thread holds no gate between two handlers; the data threads finish theirs. The
    // control shard drops its mail too: a crossing in it holds its shard (a cycle otherwise).
    // Every data thread stops before any io_context goes: one thread may hand work to another's
    // (a slot freed on a reader's thread goes to its writer's, shm_region.hpp) until it stops.
    for (std::size_t n = shards_.size(); n-- > 0;)
        shards_[n]->halt();
    for (std::size_t n = shards_.size(); n-- > 0;)
        shards_[n]->dispose();
    if (this_thread_role == &control_role)
        this_thread_role = nullptr;
}

std::size_t Shards::place() {
    if (data_threads() == 0)
        return 0;
    next_ = next_ % data_threads() + 1;
    return next_;
}

std::size_t Shards::here() {
    const ThreadRole* role = this_thread_role;
    return role ? role->shard : 0;
}

DaemonCounters Shards::total() const {
    DaemonCounters sum;
    for (const auto& shard : shards_)
        sum += shard->counters();
    return sum;
}

void Shards::space_appeared() {
    const std::size_t number = here();
    shards_[number]->space_appeared();
    if (number != 0) {
        shards_[0]->poke();
        return;
    }
    for (std::size_t n = 1; n < shards_.size(); ++n)
        shards_[n]->poke();
}

std::shared_ptr<MessageSink> Shards::crossing(std::size_t source, const std::shared_ptr<MessageSink>& sink) {
    // The control thread runs alone: from a port of its own it may deliver anywhere directly.
    if (data_threads() == 0 || source == 0 || !sink || sink->shard() == source)
        return nullptr;
    return std::make_shared<ShardCrossing>(shards_[source], shards_[sink->shard()], sink);
}

}  // namespace plexus::daemon
