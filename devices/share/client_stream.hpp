#pragma once
// The byte stream of one shared-port client, whatever carries it: a TCP connection or the master side
// of the shared pseudo-terminal. client_session reads and writes through it and never learns which.

#include <cstddef>
#include <functional>
#include <utility>

#include <boost/asio/buffer.hpp>
#include <boost/asio/write.hpp>
#include <boost/system/error_code.hpp>

namespace gw::devices::share {

class client_stream {
  public:
    using io_handler = std::function<void(boost::system::error_code, std::size_t)>;

    virtual ~client_stream() = default;
    virtual void async_read_some(boost::asio::mutable_buffer into, io_handler handler) = 0;
    // Writes all of `bytes` (which must stay valid until `handler` runs).
    virtual void async_write(boost::asio::const_buffer bytes, io_handler handler) = 0;
    // Ends pending reads and writes (they complete with operation_aborted).
    virtual void close() = 0;
};

// A client_stream over an Asio stream the session owns (a TCP socket) or borrows (the pty master, which
// outlives every program that opens the pty): `Stream` is the object or a reference to it.
template <typename Stream>
class asio_client_stream final : public client_stream {
  public:
    using close_function = std::function<void(std::remove_reference_t<Stream>&)>;

    asio_client_stream(Stream stream, close_function on_close)
        : stream_(std::forward<Stream>(stream)), on_close_(std::move(on_close)) {}

    void async_read_some(boost::asio::mutable_buffer into, io_handler handler) override {
        stream_.async_read_some(into, std::move(handler));
    }
    void async_write(boost::asio::const_buffer bytes, io_handler handler) override {
        boost::asio::async_write(stream_, bytes, std::move(handler));
    }
    void close() override { on_close_(stream_); }

  private:
    Stream stream_;
    close_function on_close_;
};

}  // namespace gw::devices::share
