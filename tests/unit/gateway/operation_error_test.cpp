#include "gateway/common/operation_error.hpp"

#include <gtest/gtest.h>

#include "devices/ms2000/error.hpp"

namespace gw {
namespace {

namespace ms2000 = devices::ms2000;
using kind = operation_error_kind;

TEST(operation_error, kinds_have_stable_names) {
    const std::pair<kind, const char*> names[] = {
        {kind::unknown_controller, "unknown_controller"},
        {kind::invalid_value, "invalid_value"},
        {kind::missing_module, "missing_module"},
        {kind::busy, "busy"},
        {kind::leased, "leased"},
        {kind::not_connected, "not_connected"},
        {kind::timeout, "timeout"},
        {kind::controller_error, "controller_error"},
        {kind::queue_full, "queue_full"},
        {kind::internal, "internal"},
    };
    for (const auto& [k, name] : names)
        EXPECT_EQ(to_string(k), name);
}

TEST(operation_error, driver_errors_map_to_kinds) {
    const std::pair<ms2000::error, kind> rows[] = {
        {ms2000::error::timeout, kind::timeout},
        {ms2000::error::not_connected, kind::not_connected},
        {ms2000::error::disconnected, kind::not_connected},
        {ms2000::error::cancelled, kind::not_connected},
        {ms2000::error::queue_full, kind::queue_full},
        {ms2000::error::invalid_argument, kind::invalid_value},
        {ms2000::error::unrecognized_reply, kind::controller_error},
        {ms2000::error::line_too_long, kind::controller_error},
    };
    for (const auto& [e, k] : rows) {
        const auto mapped = from_driver_error(e, 0, "stage1");
        EXPECT_EQ(mapped.kind, k) << ms2000::make_error_code(e).message();
        EXPECT_NE(mapped.message.find("stage1"), std::string::npos);
    }
    const auto other = from_driver_error(make_error_code(boost::system::errc::io_error), 0, "s");
    EXPECT_EQ(other.kind, kind::internal);
}

TEST(operation_error, controller_rejection_keeps_the_signed_code_and_its_name) {
    const auto e = from_driver_error(ms2000::error::controller_rejected, -4, "stage1");
    EXPECT_EQ(e.kind, kind::controller_error);
    EXPECT_EQ(e.controller_code, -4);
    EXPECT_EQ(e.controller_code_name, "parameter_out_of_range");
    EXPECT_NE(e.message.find(":N-4"), std::string::npos) << e.message;
}

}  // namespace
}  // namespace gw
