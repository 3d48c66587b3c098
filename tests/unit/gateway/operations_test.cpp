// Validation of every typed operation against a controller snapshot, before anything is sent.
#include "gateway/controllers/operations.hpp"

#include <limits>
#include <string>
#include <variant>

#include <gtest/gtest.h>

#include "devices/sim/sim_config.hpp"

namespace gw {
namespace {

using namespace std::chrono_literals;
using devices::connection_state;
using devices::controller_snapshot;
using kind = operation_error_kind;

controller_snapshot connected(const std::string& preset) {
    controller_snapshot s;
    s.id = "stage1";
    s.state = connection_state::connected;
    devices::controller_identity id;
    id.version = "9.50";
    id.build = devices::sim::make_build_info(devices::sim::preset(preset).value());
    s.identity = id;
    for (const char a : id.build.motor_axes) {
        devices::axis_state ax;
        ax.axis = a;
        ax.position_um = 1000;  // 1 mm
        ax.lower_limit_mm = -110;
        ax.upper_limit_mm = 110;
        s.axes.push_back(ax);
    }
    return s;
}

// What a plan should produce: the exact wire form, or an error kind and field.
struct expect {
    std::string wire;  // empty: an error is expected
    kind error = kind::internal;
    std::string field;
};
expect wire(std::string w) {
    return {std::move(w), kind::internal, {}};
}
expect fails(kind k, std::string field = {}) {
    return {"", k, std::move(field)};
}

template <typename Request>
void check(const Request& r, const controller_snapshot& s, const expect& e) {
    auto planned = plan(r, s);
    if (!e.wire.empty()) {
        ASSERT_TRUE(planned) << to_string(planned.error().kind) << ": " << planned.error().message;
        EXPECT_EQ(planned->wire, e.wire);
    } else {
        ASSERT_FALSE(planned) << "planned " << planned->wire;
        EXPECT_EQ(planned.error().kind, e.error) << planned.error().message;
        EXPECT_EQ(planned.error().field, e.field) << planned.error().message;
        EXPECT_FALSE(planned.error().message.empty());
    }
}

const double nan = std::numeric_limits<double>::quiet_NaN();
const double inf = std::numeric_limits<double>::infinity();

TEST(operations, move) {
    using mode = move_request::mode;
    const auto s = connected("plain");
    struct row {
        move_request r;
        expect e;
    };
    const row rows[] = {
        {{mode::absolute, {{'X', 1234.5}}}, wire("M X=12345\r")},
        {{mode::absolute, {{'x', 10}, {'Z', -20}}}, wire("M X=100 Z=-200\r")},
        {{mode::relative, {{'Y', 0.05}}}, wire("R Y=0.5\r")},
        {{mode::absolute, {{'X', 110000}}}, wire("M X=1100000\r")},  // exactly on the upper limit
        {{mode::absolute, {{'X', -110000}}}, wire("M X=-1100000\r")},
        {{mode::absolute, {}}, fails(kind::invalid_value, "axes")},
        {{mode::absolute, {{'Q', 1}}}, fails(kind::invalid_value, "axes.Q")},
        {{mode::absolute, {{'F', 1}}}, fails(kind::invalid_value, "axes.F")},  // not a motor axis of XYZ
        {{mode::absolute, {{'1', 1}}}, fails(kind::invalid_value, "axes.1")},
        {{mode::absolute, {{'X', 1}, {'x', 2}}}, fails(kind::invalid_value, "axes.X")},
        {{mode::absolute, {{'X', nan}}}, fails(kind::invalid_value, "axes.X")},
        {{mode::absolute, {{'X', inf}}}, fails(kind::invalid_value, "axes.X")},
        {{mode::absolute, {{'X', 110000.5}}}, fails(kind::invalid_value, "axes.X")},  // above SU
        {{mode::absolute, {{'Y', -110001}}}, fails(kind::invalid_value, "axes.Y")},   // below SL
        {{mode::relative, {{'X', 109000}}}, wire("R X=1090000\r")},                   // 1 mm + 109 mm = SU
        {{mode::relative, {{'X', 109001}}}, fails(kind::invalid_value, "axes.X")},
        {{mode::absolute, {{'X', 1}}, true, 0ms}, fails(kind::invalid_value, "wait_timeout")},
        {{mode::absolute, {{'X', 1}}, true, max_wait_timeout + 1ms},
         fails(kind::invalid_value, "wait_timeout")},
        {{mode::absolute, {{'X', 1}}, true, 5s}, wire("M X=10\r")},
    };
    for (const auto& row : rows) {
        SCOPED_TRACE(testing::PrintToString(row.e.wire) + " field " + row.e.field);
        check(row.r, s, row.e);
    }
}

TEST(operations, soft_limits_are_only_checked_when_known) {
    auto s = connected("plain");
    for (auto& a : s.axes) {
        a.lower_limit_mm.reset();
        a.upper_limit_mm.reset();
        a.position_um.reset();
    }
    check(move_request{move_request::mode::absolute, {{'X', 500000}}}, s, wire("M X=5000000\r"));
    check(move_request{move_request::mode::relative, {{'X', 500000}}}, s, wire("R X=5000000\r"));
    // The sanity bound still holds.
    check(move_request{move_request::mode::absolute, {{'X', 2e6}}}, s, fails(kind::invalid_value, "axes.X"));
}

TEST(operations, everything_but_halt_needs_a_connected_identified_controller) {
    for (auto state :
         {connection_state::stopped, connection_state::disconnected, connection_state::identifying}) {
        auto s = connected("planar");
        s.state = state;
        SCOPED_TRACE(std::string(devices::to_string(state)));
        check(move_request{move_request::mode::absolute, {{'X', 1}}}, s, fails(kind::not_connected));
        check(halt_request{}, s, wire("\\\r"));  // the emergency stop: the driver alone decides
        check(home_request{}, s, fails(kind::not_connected));
        check(zero_request{}, s, fails(kind::not_connected));
        check(here_request{{{'X', 0}}}, s, fails(kind::not_connected));
        check(speed_request{{{'X', 1}}}, s, fails(kind::not_connected));
        check(ttl_request{0, {}, {}}, s, fails(kind::not_connected));
        check(dac_request{1}, s, fails(kind::not_connected));
        check(led_request{1}, s, fails(kind::not_connected));
        check(raw_command_request{"W X"}, s, fails(kind::not_connected));
    }
    auto s = connected("plain");
    s.identity.reset();  // connected but not identified: cannot validate, but may always stop
    check(home_request{}, s, fails(kind::not_connected));
    check(halt_request{}, s, wire("\\\r"));
}

TEST(operations, halt_home_zero_here) {
    auto s = connected("plain");
    check(halt_request{}, s, wire("\\\r"));
    check(home_request{}, s, wire("! X Y Z\r"));
    check(home_request{"zx"}, s, wire("! Z X\r"));
    check(home_request{"XQ"}, s, fails(kind::invalid_value, "axes.Q"));
    check(home_request{"XX"}, s, fails(kind::invalid_value, "axes.X"));
    check(zero_request{}, s, wire("Z\r"));
    check(here_request{{{'X', 0}, {'Y', 12.5}}}, s, wire("H X=0 Y=125\r"));
    check(here_request{{}}, s, fails(kind::invalid_value, "axes"));
    check(here_request{{{'F', 0}}}, s, fails(kind::invalid_value, "axes.F"));
    check(here_request{{{'X', nan}}}, s, fails(kind::invalid_value, "axes.X"));
    // Moving: halting is fine, re-defining positions is not.
    s.busy = true;
    check(halt_request{}, s, wire("\\\r"));
    check(home_request{}, s, fails(kind::busy));
    check(zero_request{}, s, fails(kind::busy));
    check(here_request{{{'X', 0}}}, s, fails(kind::busy));
}

TEST(operations, speed) {
    const auto s = connected("plain");
    check(speed_request{{{'X', 5.5}}}, s, wire("S X=5.5\r"));
    check(speed_request{{{'x', 1.234567}, {'Z', max_speed_mm_s}}}, s, wire("S X=1.234567 Z=50\r"));
    check(speed_request{{}}, s, fails(kind::invalid_value, "axes"));
    check(speed_request{{{'X', 0}}}, s, fails(kind::invalid_value, "axes.X"));
    check(speed_request{{{'Y', -1}}}, s, fails(kind::invalid_value, "axes.Y"));
    check(speed_request{{{'Y', max_speed_mm_s + 0.1}}}, s, fails(kind::invalid_value, "axes.Y"));
    check(speed_request{{{'Y', nan}}}, s, fails(kind::invalid_value, "axes.Y"));
    check(speed_request{{{'T', 1}}}, s, fails(kind::invalid_value, "axes.T"));
    check(speed_request{{{'X', 1}, {'X', 2}}}, s, fails(kind::invalid_value, "axes.X"));
}

TEST(operations, ttl) {
    const auto plain = connected("plain");
    const auto full = connected("full");      // TTL_REPORT: every IN0 mode only arms the latch
    const auto planar = connected("planar");  // ARRAY + RING BUFFER, no TTL_REPORT
    check(ttl_request{0, {}, {}}, plain, wire("TTL X=0\r"));
    check(ttl_request{5, 2, {}}, plain, wire("TTL X=5 Y=2\r"));
    check(ttl_request{{}, 9, {}}, plain, wire("TTL Y=9\r"));
    check(ttl_request{{}, {}, true}, plain, wire("TTL Y=1\r"));
    check(ttl_request{{}, {}, false}, plain, wire("TTL Y=0\r"));
    check(ttl_request{30, {}, {}}, plain, wire("TTL X=30\r"));
    check(ttl_request{}, plain, fails(kind::invalid_value, ""));
    check(ttl_request{13, {}, {}}, plain, fails(kind::invalid_value, "in0_mode"));
    check(ttl_request{-1, {}, {}}, plain, fails(kind::invalid_value, "in0_mode"));
    check(ttl_request{{}, 3, {}}, plain, fails(kind::invalid_value, "out0_mode"));
    check(ttl_request{{}, 1, true}, plain, fails(kind::invalid_value, "output"));
    // Modes that need a module.
    check(ttl_request{1, {}, {}}, plain, fails(kind::missing_module, "ring_buffer"));
    check(ttl_request{12, {}, {}}, plain, fails(kind::missing_module, "ring_buffer"));
    check(ttl_request{7, {}, {}}, plain, fails(kind::missing_module, "array"));
    check(ttl_request{6, {}, {}}, plain, fails(kind::missing_module, "scan"));
    check(ttl_request{3, {}, {}}, plain, fails(kind::missing_module, "autofocus"));
    check(ttl_request{1, {}, {}}, planar, wire("TTL X=1\r"));
    check(ttl_request{7, {}, {}}, planar, wire("TTL X=7\r"));
    check(ttl_request{6, {}, {}}, planar, fails(kind::missing_module, "scan"));
    check(ttl_request{3, {}, {}}, full, wire("TTL X=3\r"));
    check(ttl_request{1, {}, {}}, full, wire("TTL X=1\r"));
}

TEST(operations, dac_and_led_need_their_modules) {
    const auto plain = connected("plain");
    const auto planar = connected("planar");
    check(dac_request{5}, plain, fails(kind::missing_module, "dac_out"));
    check(led_request{50}, plain, fails(kind::missing_module, "led_dimmer"));
    // The module check comes first: a bad value on a build without the module is still 409.
    check(dac_request{50}, plain, fails(kind::missing_module, "dac_out"));

    check(dac_request{0}, planar, wire("WRDAC X=0\r"));
    check(dac_request{2.5}, planar, wire("WRDAC X=2.5\r"));
    check(dac_request{10}, planar, wire("WRDAC X=10\r"));
    check(dac_request{10.001}, planar, fails(kind::invalid_value, "volts"));
    check(dac_request{-0.1}, planar, fails(kind::invalid_value, "volts"));
    check(dac_request{nan}, planar, fails(kind::invalid_value, "volts"));

    check(led_request{0}, planar, wire("LED X=0\r"));
    check(led_request{99}, planar, wire("LED X=99\r"));
    check(led_request{42.4, 'y'}, planar, wire("LED Y=42\r"));
    check(led_request{100}, planar, fails(kind::invalid_value, "percent"));
    check(led_request{-1}, planar, fails(kind::invalid_value, "percent"));
    check(led_request{inf}, planar, fails(kind::invalid_value, "percent"));
    check(led_request{10, 'Q'}, planar, fails(kind::invalid_value, "channel"));
}

// The wire lines of a CRISP plan, writes then reads; the refusal's message when refused.
std::string crisp_lines(const crisp_request& r, const controller_snapshot& s) {
    const auto p = plan(r, s);
    if (!p) return "refused: " + p.error().message;
    std::string out;
    for (const auto* list : {&p->writes, &p->reads})
        for (const auto& c : *list)
            out += c.wire;
    return out;
}

crisp_request crisp_with(crisp_request::action what, std::optional<double> offset = {}, bool save = false,
                         bool wait = false, std::chrono::milliseconds timeout = default_wait_timeout) {
    crisp_request r;
    r.what = what;
    r.lock_offset = offset;
    r.save = save;
    r.wait = wait;
    r.wait_timeout = timeout;
    return r;
}

TEST(operations, crisp_plans_writes_in_order_then_every_reading) {
    auto crisp = connected("crisp");
    using action = crisp_request::action;
    const std::string reads = "LK X?\rLK Y?\rLK T?\rLK Z?\rEXTRA Y?\r";  // version 9.50
    EXPECT_EQ(crisp_lines(crisp_request{}, crisp), reads);
    EXPECT_EQ(crisp_lines(crisp_with(action::lock, -20.5, true, true), crisp),
              "LK Z=-20.5\rLK F=83\rSS Z\r" + reads);
    EXPECT_EQ(crisp_lines(crisp_with(action::unlock), crisp), "LK F=85\r" + reads);
    EXPECT_EQ(crisp_lines(crisp_with(action::off), crisp), "LK F=79\r" + reads);
    crisp.identity->version = "9.53";
    EXPECT_EQ(crisp_lines(crisp_request{}, crisp), "LK X?\rLK Y?\rLK T?\rLK Z?\rEX Y?\r");

    const auto refused = [&](const crisp_request& r, const controller_snapshot& s, kind k,
                             const std::string& field) {
        const auto p = plan(r, s);
        ASSERT_FALSE(p);
        EXPECT_EQ(p.error().kind, k) << p.error().message;
        EXPECT_EQ(p.error().field, field) << p.error().message;
    };
    refused(crisp_request{}, connected("full"), kind::missing_module, "crisp");
    refused(crisp_with(action::none, 40000), crisp, kind::invalid_value, "lock_offset");
    refused(crisp_with(action::none, nan), crisp, kind::invalid_value, "lock_offset");
    refused(crisp_with(action::unlock, {}, false, true), crisp, kind::invalid_value, "wait");
    refused(crisp_with(action::lock, {}, false, true, 0ms), crisp, kind::invalid_value, "timeout_ms");
    auto away = crisp;
    away.state = connection_state::disconnected;
    refused(crisp_request{}, away, kind::not_connected, "");
}

TEST(operations, autofocus_needs_its_module_and_a_z_axis) {
    check(autofocus_request{}, connected("crisp"), wire("AF\r"));
    check(autofocus_request{}, connected("planar"), fails(kind::missing_module, "autofocus"));
    autofocus_request instant;
    instant.wait_timeout = 0ms;
    check(instant, connected("crisp"), fails(kind::invalid_value, "timeout_ms"));
    auto xy = connected("crisp");
    xy.identity->build.motor_axes = "XY";
    check(autofocus_request{}, xy, fails(kind::invalid_value));
}

TEST(operations, missing_module_message_names_the_module_and_build) {
    auto planned = plan(dac_request{5}, connected("plain"));
    ASSERT_FALSE(planned);
    EXPECT_NE(planned.error().message.find("DAC OUT"), std::string::npos) << planned.error().message;
    EXPECT_NE(planned.error().message.find("STD_XYZ"), std::string::npos) << planned.error().message;
}

TEST(operations, raw_command) {
    const auto s = connected("plain");
    check(raw_command_request{"W X Y"}, s, wire("W X Y\r"));
    check(raw_command_request{"who"}, s, wire("WHO\r"));  // the builder sends the verb upper case
    check(raw_command_request{""}, s, fails(kind::invalid_value, "command"));
    check(raw_command_request{"W X\r"}, s, fails(kind::invalid_value, "command"));
    check(raw_command_request{"W\nX"}, s, fails(kind::invalid_value, "command"));
    check(raw_command_request{std::string("W \x01")}, s, fails(kind::invalid_value, "command"));
    check(raw_command_request{std::string(devices::ms2000::max_raw_command_bytes + 1, 'W')}, s,
          fails(kind::invalid_value, "command"));
    auto shape = plan(raw_command_request{"BU X"}, s);
    ASSERT_TRUE(shape);
    EXPECT_EQ(shape->expect, devices::ms2000::reply_shape::multiline);
}

TEST(operations, hardware_order_follows_the_build) {
    const auto s = connected("plain");
    EXPECT_EQ(hardware_order({{'Z', 0}, {'x', 0}}, s), "XZ");
    EXPECT_EQ(hardware_order({{'Y', 0}}, s), "Y");
}

TEST(operations, documented_ttl_modes) {
    for (int m = 0; m <= 12; ++m)
        EXPECT_TRUE(is_documented_in0_mode(m)) << m;
    EXPECT_TRUE(is_documented_in0_mode(30));
    EXPECT_FALSE(is_documented_in0_mode(13));
    EXPECT_FALSE(is_documented_in0_mode(29));
    for (int m : {0, 1, 2, 9})
        EXPECT_TRUE(is_documented_out0_mode(m)) << m;
    for (int m : {-1, 3, 8, 10})
        EXPECT_FALSE(is_documented_out0_mode(m)) << m;
}

}  // namespace
}  // namespace gw
