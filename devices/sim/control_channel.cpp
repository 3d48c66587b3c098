#include "devices/sim/control_channel.hpp"

#include <charconv>
#include <sstream>
#include <unistd.h>

#include <boost/asio/read_until.hpp>
#include <boost/asio/streambuf.hpp>
#include <boost/asio/write.hpp>

namespace gw::devices::sim {

namespace net = boost::asio;
using stream = net::local::stream_protocol;

namespace {

std::vector<std::string_view> words(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r'))
            ++i;
        const auto start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r')
            ++i;
        if (i > start) out.push_back(line.substr(start, i - start));
    }
    return out;
}

template <typename T>
bool number(std::string_view text, T& value) {
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    return ec == std::errc{} && end == text.data() + text.size();
}

// One connection: read a line, answer a line, until the peer closes.
class control_session : public std::enable_shared_from_this<control_session> {
  public:
    control_session(stream::socket socket, std::shared_ptr<const control_channel> channel)
        : socket_(std::move(socket)), channel_(std::move(channel)) {}

    void run() { read(); }

  private:
    void read() {
        net::async_read_until(
            socket_, buffer_, '\n', [self = shared_from_this()](boost::system::error_code ec, std::size_t n) {
                if (ec) return;  // peer closed or channel stopped
                std::string line(net::buffers_begin(self->buffer_.data()),
                                 net::buffers_begin(self->buffer_.data()) + static_cast<long>(n));
                self->buffer_.consume(n);
                while (!line.empty() && (line.back() == '\n' || line.back() == '\r'))
                    line.pop_back();
                self->answer_ = self->channel_->execute(line) + "\n";
                net::async_write(self->socket_, net::buffer(self->answer_),
                                 [self](boost::system::error_code wec, std::size_t) {
                                     if (!wec) self->read();
                                 });
            });
    }

    stream::socket socket_;
    std::shared_ptr<const control_channel> channel_;
    net::streambuf buffer_{4096};
    std::string answer_;
};

}  // namespace

control_channel::control_channel(net::any_io_executor executor, std::string socket_path,
                                 std::vector<std::shared_ptr<simulator>> simulators)
    : executor_(executor),
      path_(std::move(socket_path)),
      simulators_(std::move(simulators)),
      acceptor_(executor) {}

void control_channel::start() {
    ::unlink(path_.c_str());
    const stream::endpoint endpoint(path_);
    acceptor_.open(endpoint.protocol());
    acceptor_.bind(endpoint);
    acceptor_.listen();
    accept();
}

void control_channel::stop() {
    net::post(acceptor_.get_executor(), [self = shared_from_this()] {
        boost::system::error_code ignored;
        self->acceptor_.close(ignored);
    });
    ::unlink(path_.c_str());
}

void control_channel::accept() {
    acceptor_.async_accept([self = shared_from_this()](boost::system::error_code ec, stream::socket socket) {
        if (ec == net::error::operation_aborted || !self->acceptor_.is_open()) return;
        if (!ec) std::make_shared<control_session>(std::move(socket), self)->run();
        self->accept();
    });
}

std::string control_channel::help_text() {
    return "commands: [NAME] pulse | pulse N RATE_HZ | unplug | replug | drop-next | corrupt-next | "
           "delay-next MS | split-next MS | highbit-next | echo-next | refuse-next VERB CODE | garbage N | "
           "state | list | help";
}

std::string control_channel::execute(std::string_view line) const {
    auto w = words(line);
    if (w.empty()) return "error: empty command";
    if (simulators_.empty()) return "error: no simulator";
    auto target = simulators_.front();
    for (const auto& s : simulators_) {
        if (w.size() > 1 && s->config().name == w.front()) {
            target = s;
            w.erase(w.begin());
            break;
        }
    }
    const auto verb = w.front();
    const auto argc = w.size() - 1;
    if (verb == "help") return help_text();
    if (verb == "list") {
        std::string names;
        for (const auto& s : simulators_)
            names += (names.empty() ? "" : " ") + s->config().name;
        return names;
    }
    if (verb == "state") return target->state_json();
    if (verb == "pulse") {
        if (argc == 0) {
            target->ttl_pulse();
            return "ok";
        }
        std::size_t count = 0;
        double rate = 0;
        if (argc != 2 || !number(w[1], count) || !number(w[2], rate) || rate <= 0)
            return "error: usage: pulse [N RATE_HZ]";
        target->ttl_pulse_train(count, rate);
        return "ok";
    }
    if (argc == 0) {
        if (verb == "unplug") return target->unplug(), "ok";
        if (verb == "replug") return target->replug(), "ok";
        if (verb == "drop-next") return target->drop_next_reply(), "ok";
        if (verb == "corrupt-next") return target->corrupt_next_reply(), "ok";
        if (verb == "highbit-next") return target->high_bit_next_reply(), "ok";
        if (verb == "echo-next") return target->echo_next_reply(), "ok";
    }
    if (argc == 1 && verb == "delay-next") {
        long ms = 0;
        if (!number(w[1], ms) || ms < 0) return "error: usage: delay-next MS";
        target->delay_next_reply(std::chrono::milliseconds(ms));
        return "ok";
    }
    if (argc == 1 && verb == "split-next") {
        long ms = 0;
        if (!number(w[1], ms) || ms < 0 || ms > 60000) return "error: usage: split-next MS (MS <= 60000)";
        target->split_next_reply(std::chrono::milliseconds(ms));
        return "ok";
    }
    if (argc == 2 && verb == "refuse-next") {
        long code = 0;
        if (!number(w[2], code) || code >= 0 || code < -99)
            return "error: usage: refuse-next VERB CODE (CODE -1..-99)";
        target->refuse_next_command(std::string(w[1]), static_cast<int>(code));
        return "ok";
    }
    if (argc == 1 && verb == "garbage") {
        std::size_t n = 0;
        if (!number(w[1], n) || n > 65536) return "error: usage: garbage N (N <= 65536)";
        target->emit_garbage(n);
        return "ok";
    }
    return "error: unknown command '" + std::string(verb) + "' (try help)";
}

}  // namespace gw::devices::sim
