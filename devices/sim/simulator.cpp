#include "devices/sim/simulator.hpp"

#include <array>
#include <future>

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/buffer.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <nlohmann/json.hpp>

#include "devices/sim/ms2000_model.hpp"
#include "devices/sim/paced_writer.hpp"
#include "devices/sim/pty.hpp"

namespace gw::devices::sim {

namespace net = boost::asio;
using clock = std::chrono::steady_clock;

// Everything that runs on the strand. Kept alive by its own handlers (shared_from_this) so that
// stop() can return at once while operations unwind.
class simulator_impl : public std::enable_shared_from_this<simulator_impl> {
  public:
    simulator_impl(net::any_io_executor executor, const sim_config& config, std::string link,
                   std::string report_link)
        : strand_(net::make_strand(executor)),
          config_(config),
          link_(std::move(link)),
          report_link_(std::move(report_link)),
          model_(config),
          epoch_(clock::now()),
          main_read_(strand_),
          event_timer_(strand_),
          train_timer_(strand_) {}

    ~simulator_impl() {
        close_fd(main_slave_);
        close_fd(report_slave_);
    }

    // Caller's thread, before any handler runs.
    void open() {
        main_writer_ = std::make_shared<paced_writer>(strand_, config_.baud, config_.time_scale);
        report_writer_ = std::make_shared<paced_writer>(strand_, config_.baud, config_.time_scale);
        open_main();
        if (!report_link_.empty()) {
            auto p = open_pty();
            report_slave_ = p.slave;
            report_device_ = p.slave_path;
            report_writer_->attach(p.master);
            close_fd(p.master);  // the writer holds a dup
            point_symlink(report_link_, p.slave_path);
        }
        net::dispatch(strand_, [self = shared_from_this()] { self->read_main(); });
    }

    void close() {
        net::dispatch(strand_, [self = shared_from_this()] {
            self->stopped_ = true;
            self->close_main();
            self->report_writer_->detach();
            close_fd(self->report_slave_);
            self->event_timer_.cancel();
            self->train_timer_.cancel();
        });
        remove_symlink(link_);
        if (!report_link_.empty()) remove_symlink(report_link_);
    }

    std::string device_path() const {
        std::lock_guard lock(mutex_);
        return main_device_;
    }

    void post(std::function<void(simulator_impl&)> fn) {
        net::post(strand_, [self = shared_from_this(), fn = std::move(fn)] {
            if (!self->stopped_) fn(*self);
        });
    }

    std::string state_json() const {
        std::lock_guard lock(mutex_);
        auto j = model_.state(sim_now());
        j["port"] = {{"link", link_},         {"device", main_device_},  {"plugged", !unplugged_},
                     {"bytes_in", bytes_in_}, {"bytes_out", bytes_out_}, {"bytes_dropped", main_dropped_}};
        // bytes_dropped: report bytes the port did not take (nobody reading it); a frame the line was
        // still busy for is error 87 in the model's reports_dropped instead.
        if (!report_link_.empty())
            j["report_port"] = {
                {"link", report_link_}, {"device", report_device_}, {"bytes_dropped", report_dropped_}};
        j["time_scale"] = config_.time_scale;
        j["baud"] = config_.baud;
        // The model's state may quote bytes a client sent: never throw on them.
        return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    }

    // --- strand only -------------------------------------------------------------------------

    // One edge at simulated time `at` (now by default). A train's edges keep their scheduled times
    // even when a timer fires late on a loaded machine: a pulse generator's edges do not bunch up, so
    // a late timer must not make two edges meet one frame (error 87) that the real ones would not.
    void pulse(std::optional<sim_time> at = std::nullopt) {
        std::optional<timed_output> frame;
        {
            std::lock_guard lock(mutex_);
            frame = model_.ttl_pulse(at ? *at : sim_now());
        }
        if (frame) {
            report_writer_->enqueue(std::move(frame->bytes), real_time(frame->at));
            std::lock_guard lock(mutex_);
            report_dropped_ = report_writer_->dropped_bytes();
        }
        schedule_events();
    }

    void pulse_train(std::size_t count, double rate_hz) {
        if (count == 0 || rate_hz <= 0) return;
        const auto period = std::chrono::duration_cast<clock::duration>(
            std::chrono::duration<double>(1.0 / rate_hz / config_.time_scale));
        train_next(count, period, clock::now());
    }

    void unplug() {
        if (unplugged_) return;
        close_main();
        {
            std::lock_guard lock(mutex_);
            unplugged_ = true;
            main_device_.clear();
        }
        remove_symlink(link_);
    }

    void replug() {
        if (!unplugged_) return;
        try {
            open_main();
            read_main();
        } catch (const std::system_error&) {
            // No pty available: stay unplugged; state_json() shows it.
        }
    }

    bool drop_next = false;
    bool corrupt_next = false;
    bool high_bit_next = false;
    bool echo_next = false;
    std::chrono::milliseconds delay_next{0};
    std::chrono::milliseconds split_next{0};

    void refuse_next(std::string verb, int code) {
        std::lock_guard lock(mutex_);
        model_.refuse_next(std::move(verb), code);
    }

    void garbage(std::size_t n) {
        std::string bytes;
        bytes.reserve(n);
        for (std::size_t i = 0; i < n; ++i) {
            // xorshift: deterministic noise, never CR or LF so it cannot end a reply by itself.
            rng_ ^= rng_ << 13;
            rng_ ^= rng_ >> 7;
            rng_ ^= rng_ << 17;
            auto c = static_cast<char>(rng_ & 0xFF);
            if (c == '\r' || c == '\n') c = '#';
            bytes.push_back(c);
        }
        send_main(std::move(bytes));
    }

  private:
    sim_time sim_now() const { return sim_at(clock::now()); }

    sim_time sim_at(clock::time_point t) const {
        const auto real = t - epoch_;
        return std::chrono::duration_cast<sim_time>(std::chrono::duration<double, std::micro>(
            std::chrono::duration<double, std::micro>(real).count() * config_.time_scale));
    }

    clock::time_point real_time(sim_time t) const {
        return epoch_ + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double, std::micro>(
                            static_cast<double>(t.count()) / config_.time_scale));
    }

    void open_main() {
        auto p = open_pty();
        main_writer_->attach(p.master);
        main_read_.assign(p.master);
        main_slave_ = p.slave;
        point_symlink(link_, p.slave_path);
        std::lock_guard lock(mutex_);
        main_device_ = p.slave_path;
        unplugged_ = false;
    }

    void close_main() {
        boost::system::error_code ignored;
        if (main_read_.is_open()) main_read_.close(ignored);
        main_writer_->detach();
        close_fd(main_slave_);
        ++main_generation_;
    }

    void read_main() {
        if (!main_read_.is_open()) return;
        const auto gen = main_generation_;
        main_read_.async_read_some(
            net::buffer(read_buffer_),
            [self = shared_from_this(), gen](boost::system::error_code ec, std::size_t n) {
                if (gen != self->main_generation_ || self->stopped_) return;
                if (ec) return;  // closed (unplug/stop); we hold the slave open, so no EIO otherwise
                self->on_bytes(std::string_view(self->read_buffer_.data(), n));
                self->read_main();
            });
    }

    void on_bytes(std::string_view bytes) {
        // One model call per CR, so that each reply gets its own fault decision.
        std::size_t start = 0;
        while (start < bytes.size()) {
            auto end = bytes.find('\r', start);
            end = end == std::string_view::npos ? bytes.size() : end + 1;
            std::string reply;
            {
                std::lock_guard lock(mutex_);
                bytes_in_ += end - start;
                reply = model_.feed(bytes.substr(start, end - start), sim_now());
            }
            if (!reply.empty()) send_reply(std::move(reply));
            start = end;
        }
        schedule_events();
    }

    void send_reply(std::string reply) {
        if (drop_next) {
            drop_next = false;
            return;
        }
        if (corrupt_next) {
            corrupt_next = false;
            reply[0] = static_cast<char>(reply[0] ^ 0x40);  // ':' -> 'z', 'N' -> 0x0E: unparseable
        }
        if (high_bit_next) {
            high_bit_next = false;
            auto& middle = reply[reply.size() / 2];  // never CR or LF: those end the reply
            if (middle != '\r' && middle != '\n') middle = static_cast<char>(middle | 0x80);
        }
        auto not_before = clock::time_point{};
        if (delay_next.count() > 0) {
            not_before = clock::now() + delay_next;
            delay_next = std::chrono::milliseconds{0};
        }
        if (echo_next) {
            echo_next = false;
            send_main(reply, not_before);
        }
        if (split_next.count() > 0) {
            // The first half now, the rest after the pause: a reply that arrives in two pieces.
            const auto half = reply.size() / 2;
            send_main(reply.substr(0, half), not_before);
            not_before = std::max(not_before, clock::now()) + split_next;
            reply.erase(0, half);
            split_next = std::chrono::milliseconds{0};
        }
        send_main(std::move(reply), not_before);
    }

    void send_main(std::string bytes, clock::time_point not_before = {}) {
        {
            std::lock_guard lock(mutex_);
            bytes_out_ += bytes.size();
        }
        main_writer_->enqueue(std::move(bytes), not_before);
        std::lock_guard lock(mutex_);
        main_dropped_ = main_writer_->dropped_bytes();
    }

    void schedule_events() {
        std::optional<sim_time> next;
        {
            std::lock_guard lock(mutex_);
            next = model_.next_event();
        }
        if (!next) return;
        const auto when = real_time(*next);
        if (event_armed_ && armed_for_ <= when) return;
        event_armed_ = true;
        armed_for_ = when;
        event_timer_.expires_at(when);
        event_timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
            if (ec == net::error::operation_aborted && self->stopped_) return;
            if (ec == net::error::operation_aborted) return;  // re-armed earlier; that wait runs
            self->event_armed_ = false;
            std::vector<timed_output> outs;
            {
                std::lock_guard lock(self->mutex_);
                outs = self->model_.take_output(self->sim_now());
            }
            for (auto& o : outs)
                self->send_main(std::move(o.bytes), self->real_time(o.at));
            self->schedule_events();
        });
    }

    void train_next(std::size_t left, clock::duration period, clock::time_point at) {
        train_timer_.expires_at(at);
        train_timer_.async_wait([self = shared_from_this(), left, period, at](boost::system::error_code ec) {
            if (ec || self->stopped_) return;
            self->pulse(self->sim_at(at));
            if (left > 1) self->train_next(left - 1, period, at + period);
        });
    }

    net::strand<net::any_io_executor> strand_;
    sim_config config_;
    std::string link_;
    std::string report_link_;
    mutable std::mutex mutex_;  // the model and the counters; state_json() reads from any thread
    ms2000_model model_;
    clock::time_point epoch_;
    net::posix::stream_descriptor main_read_;
    std::shared_ptr<paced_writer> main_writer_;
    std::shared_ptr<paced_writer> report_writer_;
    net::steady_timer event_timer_;
    net::steady_timer train_timer_;
    bool event_armed_ = false;
    clock::time_point armed_for_{};
    std::array<char, 1024> read_buffer_{};
    int main_slave_ = -1;
    int report_slave_ = -1;
    std::string main_device_;
    std::string report_device_;
    bool unplugged_ = false;
    bool stopped_ = false;
    std::uint64_t main_generation_ = 0;
    std::uint64_t bytes_in_ = 0;
    std::uint64_t bytes_out_ = 0;
    std::uint64_t main_dropped_ = 0;
    std::uint64_t report_dropped_ = 0;
    std::uint64_t rng_ = 0x9E3779B97F4A7C15ull;
};

simulator::simulator(executor_type executor, sim_config config)
    : executor_(std::move(executor)),
      config_(std::move(config)),
      port_link_(effective_link_path(config_)),
      report_link_(effective_report_link_path(config_)) {}

simulator::~simulator() {
    stop();
}

void simulator::start() {
    if (impl_) return;
    auto impl = std::make_shared<simulator_impl>(executor_, config_, port_link_, report_link_);
    impl->open();
    impl_ = std::move(impl);
}

void simulator::stop() {
    if (!impl_) return;
    impl_->close();
    impl_.reset();
}

std::string simulator::device_path() const {
    return impl_ ? impl_->device_path() : std::string{};
}

void simulator::ttl_pulse() {
    if (impl_) impl_->post([](simulator_impl& s) { s.pulse(); });
}

void simulator::ttl_pulse_train(std::size_t count, double rate_hz) {
    if (impl_) impl_->post([count, rate_hz](simulator_impl& s) { s.pulse_train(count, rate_hz); });
}

void simulator::unplug() {
    if (impl_) impl_->post([](simulator_impl& s) { s.unplug(); });
}

void simulator::replug() {
    if (impl_) impl_->post([](simulator_impl& s) { s.replug(); });
}

void simulator::drop_next_reply() {
    if (impl_) impl_->post([](simulator_impl& s) { s.drop_next = true; });
}

void simulator::corrupt_next_reply() {
    if (impl_) impl_->post([](simulator_impl& s) { s.corrupt_next = true; });
}

void simulator::delay_next_reply(std::chrono::milliseconds by) {
    if (impl_) impl_->post([by](simulator_impl& s) { s.delay_next = by; });
}

void simulator::split_next_reply(std::chrono::milliseconds pause) {
    if (impl_) impl_->post([pause](simulator_impl& s) { s.split_next = pause; });
}

void simulator::high_bit_next_reply() {
    if (impl_) impl_->post([](simulator_impl& s) { s.high_bit_next = true; });
}

void simulator::echo_next_reply() {
    if (impl_) impl_->post([](simulator_impl& s) { s.echo_next = true; });
}

void simulator::refuse_next_command(std::string verb, int code) {
    if (impl_)
        impl_->post([verb = std::move(verb), code](simulator_impl& s) mutable {
            s.refuse_next(std::move(verb), code);
        });
}

void simulator::emit_garbage(std::size_t bytes) {
    if (impl_) impl_->post([bytes](simulator_impl& s) { s.garbage(bytes); });
}

std::string simulator::state_json() const {
    return impl_ ? impl_->state_json() : std::string("{}");
}

}  // namespace gw::devices::sim
