// The simulator's paced writer on a real pseudo-terminal: bytes leave in order at the line rate, and a
// strand that was held up (a loaded machine) delays bytes without pushing every later byte back.
#include "devices/sim/paced_writer.hpp"

#include <chrono>
#include <future>
#include <optional>
#include <string>
#include <thread>
#include <unistd.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <gtest/gtest.h>

#include "devices/sim/pty.hpp"

namespace {

using gw::devices::sim::paced_writer;
using clock_type = paced_writer::clock;
using namespace std::chrono_literals;

// A pty whose master the writer writes on an I/O thread; the test reads the slave side.
class paced_pty : public ::testing::Test {
  protected:
    void start(unsigned baud) {
        pty_ = gw::devices::sim::open_pty();
        writer_ = std::make_shared<paced_writer>(strand_, baud, 1.0);
        writer_->attach(pty_.master);
        thread_ = std::thread([this] { io_.run(); });
    }
    void TearDown() override {
        boost::asio::post(strand_, [this] { writer_->detach(); });
        guard_.reset();
        if (thread_.joinable()) thread_.join();
        gw::devices::sim::close_fd(pty_.master);
        gw::devices::sim::close_fd(pty_.slave);
    }
    void enqueue(std::string bytes, clock_type::time_point not_before = {}) {
        boost::asio::post(strand_, [this, bytes = std::move(bytes), not_before]() mutable {
            writer_->enqueue(std::move(bytes), not_before);
        });
    }
    // Reads until `n` bytes came; returns them and when the last one arrived.
    std::pair<std::string, clock_type::time_point> read_bytes(std::size_t n) {
        std::string got;
        char buf[256];
        while (got.size() < n) {
            const auto r = ::read(pty_.slave, buf, sizeof buf);
            if (r <= 0) break;
            got.append(buf, static_cast<std::size_t>(r));
        }
        return {got, clock_type::now()};
    }

    boost::asio::io_context io_;
    boost::asio::strand<boost::asio::io_context::executor_type> strand_{io_.get_executor()};
    std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> guard_{
        io_.get_executor()};
    gw::devices::sim::pty_pair pty_;
    std::shared_ptr<paced_writer> writer_;
    std::thread thread_;
};

TEST_F(paced_pty, bytes_leave_in_order_no_faster_than_the_line) {
    start(9600);  // 960 bytes a second
    const auto t0 = clock_type::now();
    enqueue(std::string(200, 'a'));
    enqueue(std::string(200, 'b'));
    enqueue(std::string(80, 'c'));
    const auto [got, last] = read_bytes(480);
    EXPECT_EQ(got, std::string(200, 'a') + std::string(200, 'b') + std::string(80, 'c'));
    EXPECT_GE(last - t0, 480ms);  // 480 bytes of 10 bits at 9600 baud: 0.5 s
}

TEST_F(paced_pty, an_entry_due_in_the_past_goes_out_at_once) {
    start(300);  // 30 bytes a second: these 150 bytes take 5 s on an idle line
    enqueue(std::string(150, 'x'), clock_type::now() - 10s);
    const auto t0 = clock_type::now();
    const auto [got, last] = read_bytes(150);
    EXPECT_EQ(got.size(), 150u);
    EXPECT_LT(last - t0, 2500ms) << "the overdue entry was paced from now, as if the line had been idle";
}

TEST_F(paced_pty, a_held_up_strand_does_not_push_later_bytes_back) {
    start(9600);
    // Two seconds of entries that fill the line, each due when the one before has been carried, and the
    // strand held up for 1.5 s at the start, as a loaded machine would. Paced from when each write
    // completed, the line would stay 1.5 s behind to the end (3.5 s); on its own schedule it catches up.
    const auto t0 = clock_type::now() + 100ms;
    constexpr int entries = 20;
    constexpr std::size_t entry_bytes = 96;  // 100 ms at 9600 baud
    for (int i = 0; i < entries; ++i)
        enqueue(std::string(entry_bytes, static_cast<char>('a' + i)), t0 + i * 100ms);
    boost::asio::post(strand_, [] { std::this_thread::sleep_for(1500ms); });
    const auto [got, last] = read_bytes(entries * entry_bytes);
    ASSERT_EQ(got.size(), entries * entry_bytes);
    EXPECT_EQ(got.back(), static_cast<char>('a' + entries - 1));
    EXPECT_LT(last - t0, 2750ms) << "the line stayed behind the stall";
    std::promise<std::uint64_t> dropped;
    boost::asio::post(strand_, [&] { dropped.set_value(writer_->dropped_bytes()); });
    EXPECT_EQ(dropped.get_future().get(), 0u);
}

}  // namespace
