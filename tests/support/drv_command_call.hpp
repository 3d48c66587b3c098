#pragma once
// Sends a command through a controller from test code: as a future, or waiting for it with a deadline
// (a missing completion is a test failure, not a hang). Header-only, like the other drv_* helpers.

#include <chrono>
#include <future>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

#include <gtest/gtest.h>

#include "devices/serial/controller.hpp"

namespace gw::test {

using command_result = std::pair<boost::system::error_code, devices::ms2000::reply>;

// A typed command line as a command; a line the parser refuses is a test failure.
inline devices::ms2000::command raw_line(std::string_view line) {
    auto c = devices::ms2000::raw_command(line);
    EXPECT_TRUE(c.has_value()) << line;
    return c.value();
}

// The completion runs on the controller's strand and fulfils the promise.
inline std::future<command_result> submit_command(devices::controller& ctl, devices::ms2000::command cmd,
                                                  std::string request_id) {
    auto promise = std::make_shared<std::promise<command_result>>();
    auto future = promise->get_future();
    ctl.async_command(std::move(cmd), std::move(request_id),
                      [promise](boost::system::error_code ec, devices::ms2000::reply r) {
                          promise->set_value({ec, std::move(r)});
                      });
    return future;
}

inline command_result await_command(std::future<command_result> f, std::chrono::seconds deadline) {
    if (f.wait_for(deadline) != std::future_status::ready) {
        ADD_FAILURE() << "no completion within " << deadline.count() << " s";
        return {};
    }
    return f.get();
}

}  // namespace gw::test
