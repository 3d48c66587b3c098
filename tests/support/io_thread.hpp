#pragma once
// An io_context on a thread of its own, and waiting on the test's thread for an operation that
// completes there. Header-only.
//
//   test::io_thread gw_io;                                   // the gateway's side
//   auto r = test::await(registry.async_move(..., net::use_future));

#include <chrono>
#include <future>
#include <optional>
#include <thread>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "gateway/common/operation_error.hpp"

namespace gw::test {

struct io_thread {
    boost::asio::io_context io;
    std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work{
        boost::asio::make_work_guard(io)};
    std::thread thread{[this] { io.run(); }};

    // Lets run() return once the last handler has run.
    void join() {
        work.reset();
        if (thread.joinable()) thread.join();
    }
    ~io_thread() { join(); }
};

// The operation's result, or a test failure (and an internal error) when it does not complete in time.
template <typename T>
operation_result<T> await(std::future<operation_result<T>> f,
                          std::chrono::seconds timeout = std::chrono::seconds(60)) {
    if (f.wait_for(timeout) != std::future_status::ready) {
        ADD_FAILURE() << "the operation did not complete";
        return make_error(operation_error_kind::internal, "test: no completion");
    }
    return f.get();
}

}  // namespace gw::test
