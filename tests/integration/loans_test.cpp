// Zero-copy loans and in-place views (client.hpp: Port::loan, send_loan, read_view): a blob written
// in place in a port's shared memory and read where it is by readers on the same machine, never
// copied (the daemon's shm_passed / shm_copied counters and MessageView::in_place prove it), and
// every slot given back: loans not sent, views let go of, and the memory of clients killed -9.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <thread>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace loans_test {

constexpr std::size_t mib = 1024 * 1024;

void fill(std::span<std::uint8_t> bytes, std::uint32_t seed) {
    std::uint32_t x = seed * 2654435761u + 1;
    for (auto& b : bytes) {
        x = x * 1664525u + 1013904223u;
        b = static_cast<std::uint8_t>(x >> 24);
    }
}

bool filled(std::span<const std::uint8_t> bytes, std::uint32_t seed) {
    std::vector<std::uint8_t> expected(bytes.size());
    fill(expected, seed);
    return bytes.size() == expected.size() && std::memcmp(bytes.data(), expected.data(), bytes.size()) == 0;
}

/// A daemon whose regions hold every loan a test sends before any is read: a loan taken while the
/// region is full waits only a moment for a slot, then is ordinary memory, and on a slow machine
/// (a sanitizer build) the readers may be that far behind.
std::vector<std::string> roomy_regions(const TempDir& dir) {
    const auto config = dir.file("plexusd.json");
    std::ofstream(config) << R"({"shm_region_bytes": 67108864})";
    return {"--config", config};
}

std::uint64_t daemon_counter(Client& client, const std::string& key) {
    return client.stats()["daemon"][key].get<std::uint64_t>();
}

TEST(Loans_test, ALoanIsWrittenInPlaceAndReadInPlaceByAReaderOnThisMachine) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", roomy_regions(dir));
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    auto source = writer.open("/loan/source");
    auto sink = reader.open("/loan/sink");
    writer.connect(source.name(), sink.name());

    for (std::uint32_t i = 0; i < 20; ++i) {
        Loan loan = source.loan(mib);
        ASSERT_TRUE(loan.in_shared_memory());
        ASSERT_EQ(loan.bytes().size(), mib);
        fill(loan.bytes(), i);
        source.send_loan(std::move(loan));
        auto view = sink.read_view(20s);
        ASSERT_TRUE(view.has_value()) << "message " << i << " never arrived";
        EXPECT_TRUE(view->in_place());
        EXPECT_EQ(view->envelope().source, "/loan/source");
        EXPECT_TRUE(filled(view->bytes(), i)) << "message " << i << " arrived changed";
    }
    // The copying read takes loans too, and a view of a message that was not in shared memory
    // holds a copy.
    Loan loan = source.loan(mib);
    fill(loan.bytes(), 99);
    source.send_loan(std::move(loan));
    auto copied = sink.read(20s);
    ASSERT_TRUE(copied.has_value());
    ASSERT_TRUE(copied->data.is_binary());
    EXPECT_TRUE(filled(copied->data.get_binary(), 99));
    source.write(Value{{"small", 1}});
    auto small = sink.read_view(20s);
    ASSERT_TRUE(small.has_value());
    EXPECT_FALSE(small->in_place());
    EXPECT_TRUE(small->bytes().empty());
    EXPECT_EQ(small->value(), (Value{{"small", 1}}));

    EXPECT_EQ(daemon_counter(writer, "shm_passed"), 21u);
    EXPECT_EQ(daemon_counter(writer, "shm_copied"), 0u);
    // Every slot comes back once the views are gone.
    EXPECT_TRUE(eventually([&] { return daemon_counter(writer, "shm_slots") == 0; }));
}

TEST(Loans_test, FanOutToEightReadersNeverCopiesThePayload) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", roomy_regions(dir));
    Client writer({daemon.socket()});
    auto source = writer.open("/fan/source");
    std::vector<std::unique_ptr<Client>> readers;
    std::vector<Port> sinks;
    for (int r = 0; r < 8; ++r) {
        readers.push_back(std::make_unique<Client>(Client::Options{daemon.socket()}));
        sinks.push_back(readers.back()->open("/fan/sink" + std::to_string(r)));
        writer.connect(source.name(), sinks.back().name());
    }
    constexpr std::uint32_t count = 16;
    std::vector<std::jthread> reading;
    std::atomic<int> in_place{0};
    std::atomic<int> good{0};
    for (auto& sink : sinks) {
        reading.emplace_back([&sink, &in_place, &good] {
            for (std::uint32_t i = 0; i < count; ++i) {
                auto view = sink.read_view(20s);
                if (!view)
                    return;
                in_place += view->in_place() ? 1 : 0;
                good += filled(view->bytes(), i) ? 1 : 0;
            }
        });
    }
    for (std::uint32_t i = 0; i < count; ++i) {
        Loan loan = source.loan(mib);
        ASSERT_TRUE(loan.in_shared_memory());
        fill(loan.bytes(), i);
        source.send_loan(std::move(loan));
    }
    reading.clear();  // joined
    EXPECT_EQ(in_place.load(), 8 * static_cast<int>(count));
    EXPECT_EQ(good.load(), 8 * static_cast<int>(count));
    EXPECT_EQ(daemon_counter(writer, "shm_passed"), count);  // one message, passed on to all eight
    EXPECT_EQ(daemon_counter(writer, "shm_copied"), 0u);
    EXPECT_TRUE(eventually([&] { return daemon_counter(writer, "shm_slots") == 0; }));
}

TEST(Loans_test, AReaderThatNeedsACopyGetsOneAndTheLocalViewStillWorks) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", roomy_regions(dir));
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    auto source = writer.open("/mixed/source");
    auto local = reader.open("/mixed/local");
    auto over_tcp = reader.open("/mixed/tcp");
    writer.connect(source.name(), local.name());
    ASSERT_EQ(writer.connect(source.name(), over_tcp.name(), "tcp"), "tcp");

    for (std::uint32_t i = 0; i < 4; ++i) {
        Loan loan = source.loan(mib);
        fill(loan.bytes(), i);
        source.send_loan(std::move(loan));
    }
    for (std::uint32_t i = 0; i < 4; ++i) {
        auto view = local.read_view(20s);
        ASSERT_TRUE(view.has_value());
        EXPECT_FALSE(view->in_place());  // copied out by the daemon for the tcp reader, so for all
        EXPECT_TRUE(filled(view->bytes(), i));
        auto remote = over_tcp.read(20s);
        ASSERT_TRUE(remote.has_value());
        EXPECT_TRUE(filled(remote->data.get_binary(), i));
    }
    EXPECT_EQ(daemon_counter(writer, "shm_copied"), 4u);
}

TEST(Loans_test, LoansNotSentAreGivenBackAndViewsReleaseInAnyOrder) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", roomy_regions(dir));
    Client writer({daemon.socket()});
    Client reader({daemon.socket()});
    auto source = writer.open("/back/source");
    auto sink = reader.open("/back/sink");
    writer.connect(source.name(), sink.name());
    // More loans than the 64 MiB region holds, none sent: each one's slot comes back.
    for (int i = 0; i < 80; ++i) {
        Loan loan = source.loan(mib);
        EXPECT_TRUE(loan.in_shared_memory()) << "loan " << i;
    }
    // Views let go of newest first: the daemon frees every slot once all are gone.
    for (std::uint32_t i = 0; i < 4; ++i) {
        Loan loan = source.loan(mib);
        fill(loan.bytes(), i);
        source.send_loan(std::move(loan));
    }
    std::vector<MessageView> views;
    for (int i = 0; i < 4; ++i) {
        auto view = sink.read_view(20s);
        ASSERT_TRUE(view.has_value());
        views.push_back(std::move(*view));
    }
    EXPECT_EQ(daemon_counter(writer, "shm_slots"), 4u);
    while (!views.empty())
        views.pop_back();
    EXPECT_TRUE(eventually([&] { return daemon_counter(writer, "shm_slots") == 0; }));
}

TEST(Loans_test, WithoutSharedMemoryALoanIsOrdinaryMemoryAndArrivesTheSame) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", roomy_regions(dir));
    ::setenv("PLEXUS_SHM", "0", 1);
    Client writer({daemon.socket()});
    ::unsetenv("PLEXUS_SHM");
    Client reader({daemon.socket()});
    auto source = writer.open("/heap/source");
    auto sink = reader.open("/heap/sink");
    writer.connect(source.name(), sink.name());
    Loan loan = source.loan(mib);
    EXPECT_FALSE(loan.in_shared_memory());
    fill(loan.bytes(), 7);
    source.send_loan(std::move(loan));
    auto view = sink.read_view(20s);
    ASSERT_TRUE(view.has_value());
    EXPECT_FALSE(view->in_place());
    EXPECT_TRUE(filled(view->bytes(), 7));
}

TEST(Loans_test, ClientsKilledWithLoansAndViewsOutstandingGiveEverySlotAndRegionBack) {
    TempDir dir;
    Daemon daemon(dir, "solo", "", roomy_regions(dir));
    Client observer({daemon.socket()});
    Process viewer({PLEXUS_LOAN_CLIENT, daemon.socket(), "view", "/killed/sink"}, {}, dir.file("viewer"));
    ASSERT_TRUE(eventually([&] { return observer.lookup("/killed/sink").has_value(); }));
    Process loaner(
        {PLEXUS_LOAN_CLIENT, daemon.socket(), "write", "/killed/source", "/killed/sink", std::to_string(mib)},
        {}, dir.file("loaner"));
    // The viewer holds views (so the daemon holds slots for it), the loaner holds loans not sent.
    ASSERT_TRUE(eventually([&] { return viewer.out().find("holding 3") != std::string::npos; }, 20s))
        << viewer.err() << loaner.err();
    EXPECT_GT(daemon_counter(observer, "shm_slots"), 0u);
    EXPECT_GT(daemon_counter(observer, "shm_regions"), 0u);
    loaner.signal(SIGKILL);
    viewer.signal(SIGKILL);
    loaner.wait();
    viewer.wait();
    EXPECT_TRUE(eventually([&] { return daemon_counter(observer, "shm_slots") == 0; }))
        << observer.stats()["daemon"].dump();
    EXPECT_TRUE(eventually([&] { return daemon_counter(observer, "shm_regions") == 0; }))
        << observer.stats()["daemon"].dump();
    EXPECT_EQ(daemon_counter(observer, "shm_bytes"), 0u);
}

}  // namespace loans_test
}  // namespace plexus::test
