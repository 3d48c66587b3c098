#include "devices/sim/paced_writer.hpp"

#include <algorithm>
#include <cmath>
#include <unistd.h>

#include <boost/asio/buffer.hpp>
#include <boost/asio/write.hpp>

namespace gw::devices::sim {

paced_writer::paced_writer(const boost::asio::any_io_executor& executor, unsigned baud, double time_scale)
    : executor_(executor), stream_(executor), timer_(executor) {
    const double scale = time_scale > 0 ? time_scale : 1.0;
    const double byte_seconds = 10.0 / std::max(baud, 1u) / scale;
    byte_time_ = std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(byte_seconds));
    // About one millisecond of bytes per write: fine-grained pacing without a timer per byte.
    chunk_bytes_ = static_cast<std::size_t>(std::max(1.0, std::floor(0.001 / byte_seconds)));
}

void paced_writer::attach(int master_fd) {
    detach();
    const int fd = ::dup(master_fd);
    if (fd >= 0) stream_.assign(fd);
}

void paced_writer::detach() {
    ++generation_;
    boost::system::error_code ignored;
    if (stream_.is_open()) stream_.close(ignored);
    timer_.cancel();
    queue_.clear();
    busy_ = false;
}

std::size_t paced_writer::queued_bytes() const {
    std::size_t n = 0;
    for (const auto& e : queue_)
        n += e.bytes.size() - e.offset;
    return n;
}

void paced_writer::enqueue(std::string bytes, clock::time_point not_before) {
    if (bytes.empty() || !stream_.is_open()) return;
    if (queued_bytes() + bytes.size() > max_queued_bytes) {
        dropped_bytes_ += bytes.size();
        return;
    }
    if (not_before == clock::time_point{}) not_before = clock::now();
    queue_.push_back({std::move(bytes), 0, not_before});
    pump();
}

void paced_writer::pump() {
    if (busy_ || queue_.empty() || !stream_.is_open()) return;
    auto& e = queue_.front();
    const auto n = std::min(chunk_bytes_, e.bytes.size() - e.offset);
    // The last byte of the chunk reaches the client when the line has carried all n bytes. The line
    // is free when its schedule says so, not when the last write completed (see the header).
    const auto start = std::max(line_free_, e.not_before);
    const auto deliver_at = start + byte_time_ * static_cast<long>(n);
    busy_ = true;
    const auto gen = generation_;
    timer_.expires_at(deliver_at);
    timer_.async_wait([self = shared_from_this(), gen, n, deliver_at](boost::system::error_code ec) {
        if (ec || gen != self->generation_) return;
        auto& front = self->queue_.front();
        auto chunk = std::make_shared<std::string>(front.bytes.substr(front.offset, n));
        boost::asio::async_write(
            self->stream_, boost::asio::buffer(*chunk),
            [self, gen, chunk, deliver_at](boost::system::error_code wec, std::size_t written) {
                if (gen != self->generation_) return;
                self->busy_ = false;
                self->line_free_ = deliver_at;
                if (wec) {  // the port is gone; the owner notices on its read side
                    self->queue_.clear();
                    return;
                }
                self->bytes_written_ += written;
                auto& f = self->queue_.front();
                f.offset += written;
                if (f.offset >= f.bytes.size()) self->queue_.pop_front();
                self->pump();
            });
    });
}

}  // namespace gw::devices::sim
