#include "devices/share/shared_report_port.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <utility>

#include <boost/asio/ip/address.hpp>

#include "devices/share/tcp_listener.hpp"

namespace gw::devices::share {

namespace net = boost::asio;
using boost::system::error_code;
using net::ip::tcp;

struct shared_report_port::reader {
    std::unique_ptr<client_stream> stream;
    client_status status;
    std::array<char, 256> input{};  // what the program sends: read so that its leaving is seen, dropped
    std::string writing;
    std::string next;
    bool gone = false;
};

shared_report_port::shared_report_port(const net::strand<net::any_io_executor>& strand,
                                       const share_settings& settings)
    : strand_(strand), settings_(settings), pty_(strand_), pty_watch_(strand_) {}

std::string shared_report_port::start(std::function<void()> changed) {
    changed_ = std::move(changed);
    if (!settings_.report_pty.empty()) {
        auto pty_settings = settings_;
        pty_settings.pty = settings_.report_pty;
        std::string warning;
        if (auto why = pty_.open(pty_settings, warning); !why.empty())
            return "shared report pty " + settings_.report_pty + ": " + why;
    }
    if (settings_.report_tcp_port != 0) {
        error_code ec;
        const tcp::endpoint at(net::ip::make_address(settings_.report_tcp_host, ec),
                               settings_.report_tcp_port);
        if (!ec) {
            acceptor_.emplace(strand_);
            ec = open_listener(*acceptor_, at);
        }
        if (ec) {
            pty_.close();
            return "shared report TCP port " + settings_.report_tcp_host + ":" +
                   std::to_string(settings_.report_tcp_port) + ": " + ec.message();
        }
    }
    net::dispatch(strand_, [self = shared_from_this()] {
        if (self->pty_.is_open()) self->watch_pty();
        if (self->acceptor_) self->accept();
    });
    return {};
}

std::string shared_report_port::tcp() const {
    if (!acceptor_) return {};
    error_code ec;
    const auto at = acceptor_->local_endpoint(ec);
    return ec ? std::string() : at.address().to_string() + ":" + std::to_string(at.port());
}

void shared_report_port::stop() {
    stopped_ = true;
    pty_watch_.cancel();
    if (acceptor_) {
        error_code ignored;
        acceptor_->close(ignored);
    }
    std::vector<std::shared_ptr<reader>> all;
    all.swap(tcp_readers_);
    if (pty_reader_) all.push_back(std::move(pty_reader_));
    for (auto& r : all) {
        r->gone = true;
        r->stream->close();
    }
    pty_.close();
}

void shared_report_port::deliver(std::string_view bytes) {
    auto send = [&](const std::shared_ptr<reader>& r) {
        if (r->writing.size() + r->next.size() + bytes.size() > settings_.max_output_bytes) {
            r->status.dropped_bytes += bytes.size();
            return;
        }
        r->next.append(bytes);
        write(r);
    };
    if (pty_reader_) send(pty_reader_);
    for (const auto& r : tcp_readers_)
        send(r);
}

std::vector<client_status> shared_report_port::readers() const {
    std::vector<client_status> out;
    if (pty_reader_) out.push_back(pty_reader_->status);
    for (const auto& r : tcp_readers_)
        out.push_back(r->status);
    return out;
}

void shared_report_port::accept() {
    acceptor_->async_accept(strand_, [self = shared_from_this()](error_code ec, tcp::socket socket) {
        if (self->stopped_ || ec == net::error::operation_aborted) return;
        if (!ec) {
            const auto peer = socket.remote_endpoint(ec);
            if (self->tcp_readers_.size() >= self->settings_.max_clients) {
                socket.close(ec);
            } else {
                auto r = std::make_shared<reader>();
                r->status.name =
                    "report tcp " +
                    (ec ? std::string("?") : peer.address().to_string() + ":" + std::to_string(peer.port()));
                r->stream =
                    std::make_unique<asio_client_stream<tcp::socket>>(std::move(socket), [](tcp::socket& s) {
                        error_code ignored;
                        s.close(ignored);
                    });
                self->tcp_readers_.push_back(r);
                self->start_reader(r);
            }
        }
        self->accept();
    });
}

void shared_report_port::watch_pty() {
    if (stopped_ || pty_reader_) return;
    if (pty_.program_present()) {
        auto r = std::make_shared<reader>();
        r->status.name = "report pty";
        r->stream = std::make_unique<asio_client_stream<net::posix::stream_descriptor&>>(
            pty_.master(), [](net::posix::stream_descriptor& master) {
                error_code ignored;
                master.cancel(ignored);
            });
        pty_reader_ = r;
        return start_reader(r);
    }
    pty_watch_.expires_after(std::chrono::milliseconds(100));
    pty_watch_.async_wait([self = shared_from_this()](error_code ec) {
        if (!ec) self->watch_pty();
    });
}

void shared_report_port::start_reader(const std::shared_ptr<reader>& r) {
    r->status.since = std::chrono::system_clock::now();
    if (changed_) changed_();
    drain(r);
}

void shared_report_port::drain(const std::shared_ptr<reader>& r) {
    r->stream->async_read_some(net::buffer(r->input),
                               [self = shared_from_this(), r](error_code ec, std::size_t) {
                                   if (ec || r->gone) return self->remove(r);
                                   self->drain(r);
                               });
}

void shared_report_port::write(const std::shared_ptr<reader>& r) {
    if (r->gone || !r->writing.empty() || r->next.empty()) return;
    r->writing.swap(r->next);
    r->stream->async_write(net::buffer(r->writing),
                           [self = shared_from_this(), r](error_code ec, std::size_t) {
                               r->writing.clear();
                               if (ec) return self->remove(r);
                               self->write(r);
                           });
}

void shared_report_port::remove(const std::shared_ptr<reader>& r) {
    if (r->gone && r != pty_reader_ &&
        std::find(tcp_readers_.begin(), tcp_readers_.end(), r) == tcp_readers_.end())
        return;
    r->gone = true;
    r->stream->close();
    if (r == pty_reader_) {
        pty_reader_.reset();
        watch_pty();
    } else {
        std::erase(tcp_readers_, r);
    }
    if (changed_ && !stopped_) changed_();
}

}  // namespace gw::devices::share
