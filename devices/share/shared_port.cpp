#include "devices/share/shared_port.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/ip/address.hpp>
#include <boost/asio/post.hpp>
#include <spdlog/spdlog.h>

#include "devices/ms2000/error.hpp"
#include "devices/share/tcp_listener.hpp"

namespace gw::devices::share {

namespace net = boost::asio;
using boost::system::error_code;
using net::ip::tcp;

namespace {

// How often the pty is checked for a program that opened it (the master reports a hang-up until one
// does, so there is nothing to wait on).
constexpr std::chrono::milliseconds pty_watch_interval{100};

std::string endpoint_text(const tcp::endpoint& e) {
    const auto address = e.address().to_string();
    return (e.address().is_v6() ? "[" + address + "]" : address) + ":" + std::to_string(e.port());
}

}  // namespace

shared_port::shared_port(const net::any_io_executor& executor, share_settings settings,
                         std::shared_ptr<controller> controller, std::shared_ptr<share_gate> gate)
    : strand_(net::make_strand(executor)),
      settings_(std::move(settings)),
      controller_(std::move(controller)),
      gate_(std::move(gate)),
      log_(spdlog::get("ms2000." + settings_.controller)),
      pty_(strand_),
      pty_watch_(strand_),
      accept_retry_(strand_) {
    if (!log_) log_ = spdlog::default_logger();
    published_.controller = settings_.controller;
    published_.role = to_string(settings_.role);
    published_.lease = settings_.lease;
}

shared_port::~shared_port() = default;

std::string shared_port::start() {
    if (!settings_.pty.empty()) {
        std::string warning;
        if (auto why = pty_.open(settings_, warning); !why.empty())
            return "shared pty " + settings_.pty + ": " + why;
        if (!warning.empty()) log_->warn("shared pty {}: {}", settings_.pty, warning);
    }
    if (settings_.tcp_port != 0) {
        error_code ec;
        const auto address = net::ip::make_address(settings_.tcp_host, ec);
        if (ec) return "shared TCP port: \"" + settings_.tcp_host + "\" is not an IP address";
        acceptor_.emplace(strand_);
        const tcp::endpoint at(address, settings_.tcp_port);
        ec = open_listener(*acceptor_, at);
        if (ec) {
            pty_.close();
            return "shared TCP port " + endpoint_text(at) + ": " + ec.message();
        }
    }
    if (settings_.shares_reports()) {
        reports_ = std::make_shared<shared_report_port>(strand_, settings_);
        if (auto why = reports_->start([self = weak_from_this()] {
                if (auto port = self.lock()) port->publish();
            });
            !why.empty()) {
            pty_.close();
            error_code ignored;
            if (acceptor_) acceptor_->close(ignored);
            return why;
        }
        // The controller's strand hands each read over to this port's strand, copied.
        controller_->set_report_tap([self = weak_from_this()](std::string_view bytes) {
            auto port = self.lock();
            if (!port) return;
            net::post(port->strand_, [port, copy = std::string(bytes)] {
                if (!port->stopped_) port->reports_->deliver(copy);
            });
        });
    }
    {
        std::lock_guard lock(status_mutex_);
        published_.pty = settings_.pty;
        if (reports_) {
            published_.report_pty = reports_->pty();
            published_.report_tcp = reports_->tcp();
        }
        if (acceptor_) published_.tcp = endpoint_text(acceptor_->local_endpoint());
    }
    net::dispatch(strand_, [self = shared_from_this()] {
        if (self->pty_.is_open()) self->watch_pty();
        if (self->acceptor_) self->accept();
    });
    return {};
}

void shared_port::stop() {
    net::dispatch(strand_, [self = shared_from_this()] {
        if (self->stopped_) return;
        self->stopped_ = true;
        self->pty_watch_.cancel();
        self->accept_retry_.cancel();
        if (self->acceptor_) {
            error_code ignored;
            self->acceptor_->close(ignored);
        }
        std::vector<std::shared_ptr<client_session>> sessions;
        sessions.swap(self->tcp_sessions_);  // left empty: the sessions' ends find nothing to remove
        if (self->pty_session_) sessions.push_back(std::move(self->pty_session_));
        for (auto& s : sessions)
            s->close();
        self->pty_.close();
        if (self->reports_) {
            self->controller_->set_report_tap({});
            self->reports_->stop();
        }
        self->clients_changed();
    });
}

port_status shared_port::status() const {
    std::lock_guard lock(status_mutex_);
    return published_;
}

void shared_port::accept() {
    acceptor_->async_accept(strand_, [self = shared_from_this()](error_code ec, tcp::socket socket) {
        if (self->stopped_) return;
        if (ec) {
            // A transient failure (too many open files): try again shortly rather than spin.
            self->log_->warn("shared TCP port: accept failed: {}", ec.message());
            self->accept_retry_.expires_after(std::chrono::milliseconds(100));
            return self->accept_retry_.async_wait([self](error_code e) {
                if (!e && !self->stopped_) self->accept();
            });
        }
        const auto peer = socket.remote_endpoint(ec);
        const std::string name = "tcp " + (ec ? std::string("?") : endpoint_text(peer));
        if (self->tcp_sessions_.size() >= self->settings_.max_clients) {
            ++self->clients_refused_;
            self->log_->warn(
                "shared TCP port: {} closed at once: {} clients are connected (share.max_clients)", name,
                self->tcp_sessions_.size());
            socket.close(ec);
            self->publish();
            return self->accept();
        }
        socket.set_option(tcp::no_delay(true), ec);  // one reply line is one segment, sent at once
        auto stream =
            std::make_unique<asio_client_stream<tcp::socket>>(std::move(socket), [](tcp::socket& s) {
                error_code ignored;
                s.shutdown(tcp::socket::shutdown_both, ignored);
                s.close(ignored);
            });
        auto session = std::make_shared<client_session>(std::move(stream), self, name, self->settings_, true);
        self->tcp_sessions_.push_back(session);
        self->log_->info("shared port: {} connected", name);
        session->start();
        self->clients_changed();
        self->accept();
    });
}

void shared_port::watch_pty() {
    if (stopped_ || pty_session_) return;
    if (pty_.program_present()) {
        auto stream = std::make_unique<asio_client_stream<net::posix::stream_descriptor&>>(
            pty_.master(), [](net::posix::stream_descriptor& master) {
                error_code ignored;
                master.cancel(ignored);  // the master stays: the next program opens the same pty
            });
        pty_session_ =
            std::make_shared<client_session>(std::move(stream), shared_from_this(), "pty", settings_, false);
        log_->info("shared port: a program opened {}", settings_.pty);
        pty_session_->start();
        clients_changed();
        return;
    }
    pty_watch_.expires_after(pty_watch_interval);
    pty_watch_.async_wait([self = shared_from_this()](error_code ec) {
        if (!ec) self->watch_pty();
    });
}

void shared_port::session_ended(const std::shared_ptr<client_session>& session) {
    if (session == pty_session_) {
        log_->info("shared port: the program that had {} open closed it", settings_.pty);
        pty_session_.reset();
        clients_changed();
        return watch_pty();
    }
    const auto it = std::find(tcp_sessions_.begin(), tcp_sessions_.end(), session);
    if (it == tcp_sessions_.end()) return;
    log_->info("shared port: {} disconnected", session->name());
    tcp_sessions_.erase(it);
    clients_changed();
}

void shared_port::refuse(client_session& from, const refusal& why, const std::string& line) {
    from.count_refused();
    ++refused_;
    log_->warn("shared port: {}: \"{}\" refused ({}): {}", from.name(), line, static_cast<int>(why.code),
               why.reason);
    publish();
}

void shared_port::run_line(const std::shared_ptr<client_session>& from, std::string line,
                           std::chrono::steady_clock::time_point arrived,
                           std::function<void(std::string)> answer) {
    auto cmd = ms2000::verbatim_command(line);
    if (!cmd) {
        refuse(*from, {refusal_code::unreadable, "not a command the controller could read"}, line);
        return answer(refusal_reply(refusal_code::unreadable));
    }
    const auto effect = ms2000::effect_of(*cmd);
    // What moves or changes something, and HALT, goes into the gateway's audit trail, sent or refused.
    const bool halt = effect == ms2000::command_effect::halts;
    const bool audited = gate_ && (needs_control(effect) || halt);
    const auto audit = [&](std::string outcome, std::string reason) {
        if (audited)
            gate_->record(settings_.controller,
                          {from->name(), line, settings_.role, std::move(outcome), std::move(reason), halt});
    };
    if (!role_allows(settings_.role, effect)) {
        refusal why{refusal_code::role, std::string("a command that ") + ms2000::to_string(effect) +
                                            " needs a higher share.role than " + to_string(settings_.role)};
        refuse(*from, why, line);
        audit("forbidden", why.reason);
        return answer(refusal_reply(refusal_code::role));
    }
    if (needs_control(effect) && gate_) {
        if (auto refused = gate_->admit(settings_.controller)) {
            refuse(*from, *refused, line);
            audit("held-elsewhere", refused->reason);
            return answer(refusal_reply(refused->code));
        }
    }
    if (effect == ms2000::command_effect::halts) {
        log_->warn("shared port: HALT from {}", from->name());
        if (gate_) gate_->halting(settings_.controller, from->name());
    }
    // A real controller answers within the gateway's own command timeout of the line's arrival; a
    // program that waited that long has given up. A line that waited longer behind the client's earlier
    // ones (a resynchronisation held them) is not sent at all: it would act late. An answer later than
    // that would be read as the answer to the program's next line: it gets silence instead.
    const auto& link = controller_->settings();
    const auto answer_by = arrived + (cmd->long_reply ? link.long_reply_timeout : link.command_timeout);
    if (effect != ms2000::command_effect::halts && std::chrono::steady_clock::now() > answer_by) {
        from->count_late();
        publish();
        audit("late", "waited longer than the command timeout behind the client's earlier lines: not sent");
        return answer({});
    }
    from->count_sent();
    ++commands_;
    const auto request_id = "share-" + std::to_string(++line_sequence_);
    controller_->async_command(
        std::move(*cmd), request_id,
        net::bind_executor(strand_, [self = shared_from_this(), from, answer = std::move(answer), answer_by,
                                     audited, halt, line](error_code ec, const ms2000::reply& reply) {
            self->publish();
            const bool answered = !ec || ec == ms2000::error::controller_rejected;
            if (audited)
                self->gate_->record(self->settings_.controller,
                                    {from->name(),
                                     line,
                                     self->settings_.role,
                                     !ec ? "ok" : (answered ? "controller-error" : "no-answer"),
                                     {},
                                     halt});
            if (answered && std::chrono::steady_clock::now() > answer_by) {
                from->count_late();
                return answer({});
            }
            // The controller's answer, its ":N-<code>" refusal included, goes back as it came.
            if (answered) return answer(reply.raw + "\r\n");
            if (ec == ms2000::error::queue_full) return answer(refusal_reply(refusal_code::busy));
            answer({});  // no answer: not connected, timed out, an answer that did not fit
        }));
}

void shared_port::clients_changed() {
    const std::size_t connected = tcp_sessions_.size() + (pty_session_ ? 1 : 0);
    if (gate_ && settings_.lease) holds_lease_ = gate_->clients_changed(settings_.controller, connected);
    publish();
}

void shared_port::publish() {
    std::vector<client_status> clients;
    if (pty_session_) clients.push_back(pty_session_->status());
    for (const auto& s : tcp_sessions_)
        clients.push_back(s->status());
    auto readers = reports_ ? reports_->readers() : std::vector<client_status>{};
    std::lock_guard lock(status_mutex_);
    published_.clients = std::move(clients);
    published_.report_readers = std::move(readers);
    published_.commands = commands_;
    published_.refused = refused_;
    published_.clients_refused = clients_refused_;
    published_.holds_lease = holds_lease_;
}

}  // namespace gw::devices::share
