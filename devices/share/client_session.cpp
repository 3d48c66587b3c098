#include "devices/share/client_session.hpp"

#include <algorithm>
#include <utility>

#include "devices/ms2000/command.hpp"

namespace gw::devices::share {

namespace {

// A HALT line ("\" or "HALT", any case, spaces around): it goes out at once, ahead of waiting lines.
bool is_halt_line(std::string_view line) {
    const auto start = line.find_first_not_of(' ');
    if (start == std::string_view::npos) return false;
    line.remove_prefix(start);
    line = line.substr(0, std::min(line.find_last_not_of(' ') + 1, line.size()));
    if (line == "\\") return true;
    if (line.size() != 4) return false;
    for (std::size_t i = 0; i < 4; ++i)
        if ((line[i] & ~0x20) != "HALT"[i]) return false;
    return true;
}

}  // namespace

client_session::client_session(std::unique_ptr<client_stream> stream, std::shared_ptr<owner> owner,
                               std::string name, const share_settings& settings, bool telnet)
    : stream_(std::move(stream)),
      owner_(std::move(owner)),
      settings_(settings),
      reader_(ms2000::max_raw_command_bytes) {
    if (telnet) telnet_.emplace(settings.line_baud);
    status_.name = std::move(name);
    status_.since = std::chrono::system_clock::now();
}

void client_session::start() {
    read();
}

void client_session::close() {
    if (closed_) return;
    closed_ = true;
    stream_->close();
}

void client_session::read() {
    if (reading_ || closed_ || waiting_.size() >= settings_.max_queued_lines) return;
    reading_ = true;
    stream_->async_read_some(
        boost::asio::buffer(read_buffer_),
        [self = shared_from_this()](boost::system::error_code ec, std::size_t n) { self->on_read(ec, n); });
}

void client_session::on_read(boost::system::error_code ec, std::size_t bytes) {
    reading_ = false;
    if (ec || closed_) return end();
    const std::string_view received(read_buffer_.data(), bytes);
    if (telnet_) {
        std::string data;
        std::string reply;
        telnet_->feed(received, data, reply);
        if (!reply.empty()) send(std::move(reply), false);  // negotiation answers: never escaped
        take_lines(data);
    } else {
        take_lines(received);
    }
    pump();
    read();
}

void client_session::take_lines(std::string_view data) {
    std::vector<client_line> lines;
    reader_.feed(data, lines);
    const auto now = std::chrono::steady_clock::now();
    for (auto& line : lines) {
        if (line.what == client_line::kind::command && is_halt_line(line.text)) {
            // Not behind this client's waiting lines: a HALT must not wait for anything.
            owner_->run_line(shared_from_this(), std::move(line.text), now,
                             [self = shared_from_this()](std::string a) { self->send(std::move(a)); });
            continue;
        }
        waiting_.push_back({std::move(line), now});
    }
}

void client_session::pump() {
    while (!line_out_ && !closed_ && !waiting_.empty()) {
        client_line line = std::move(waiting_.front().line);
        // The client waits for this answer from when it sent the line, or, when it sent lines ahead
        // (a pipelining program), from when it got the answer before: unless that was silence, after
        // which it may have given up on the lines it had sent meanwhile.
        const auto arrived =
            previous_silent_ ? waiting_.front().arrived : std::max(waiting_.front().arrived, last_answered_);
        waiting_.pop_front();
        // An unreadable line goes to the owner as an empty one, which it refuses as not a command: its
        // refusal then takes its turn among the client's answers.
        if (line.what == client_line::kind::unreadable) line.text.clear();
        line_out_ = true;
        owner_->run_line(shared_from_this(), std::move(line.text), arrived,
                         [self = shared_from_this()](std::string a) {
                             self->line_out_ = false;
                             self->previous_silent_ = a.empty();
                             self->last_answered_ = std::chrono::steady_clock::now();
                             self->send(std::move(a));
                             self->pump();
                             self->read();
                         });
    }
}

void client_session::send(std::string bytes, bool escape) {
    if (closed_ || bytes.empty()) return;
    std::string encoded;
    if (telnet_ && escape)
        telnet_->encode(bytes, encoded);
    else
        encoded = std::move(bytes);
    if (writing_.size() + next_.size() + encoded.size() > settings_.max_output_bytes) {
        status_.dropped_bytes += encoded.size();
        return;
    }
    next_ += encoded;
    write();
}

void client_session::write() {
    if (!writing_.empty() || next_.empty() || closed_) return;
    writing_.swap(next_);
    stream_->async_write(boost::asio::buffer(writing_),
                         [self = shared_from_this()](boost::system::error_code ec, std::size_t) {
                             self->writing_.clear();
                             if (ec) return self->end();
                             self->write();
                         });
}

void client_session::end() {
    if (ended_) return;
    ended_ = true;
    close();
    waiting_.clear();
    owner_->session_ended(shared_from_this());
}

}  // namespace gw::devices::share
