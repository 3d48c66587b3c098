#include "gateway/events/controller_events_bridge.hpp"

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/ms2000/build_info.hpp"
#include "gateway/events/controller_state_texts.hpp"
#include "gateway/events/event_hub.hpp"
#include "gateway/events/event_json.hpp"

namespace {

using namespace std::chrono;
using nlohmann::json;

class collecting_sink final : public gw::event_sink {
  public:
    void deliver(std::vector<std::shared_ptr<const gw::event>> batch) override {
        for (auto& e : batch)
            events.push_back(std::move(e));
        hub->request_more(id);
    }
    void close(std::string) override {}

    std::vector<std::shared_ptr<const gw::event>> on(const std::string& topic) const {
        std::vector<std::shared_ptr<const gw::event>> out;
        for (const auto& e : events)
            if (e->topic == topic) out.push_back(e);
        return out;
    }

    std::shared_ptr<gw::event_hub> hub;
    gw::subscriber_id id = 0;
    std::vector<std::shared_ptr<const gw::event>> events;
};

system_clock::time_point at_ms(std::int64_t ms) {
    return system_clock::time_point(milliseconds(ms));
}

gw::devices::controller_snapshot connected_snapshot() {
    using namespace gw::devices;
    controller_snapshot s;
    s.id = "stage1";
    s.state = connection_state::connected;
    s.port = "/dev/ttyUSB0";
    auto build =
        ms2000::parse_build_x("STD_XYZ\rMotor Axes: X Y Z\rRING BUFFER\rARRAY MODULE\rTTL_REPORT_INT");
    EXPECT_TRUE(build.has_value());
    s.identity = controller_identity{"9.52", ":A Version: USB-9.52", *build};
    s.axes = {
        {'X', 1234.5, false, 45396.6, -110.0, 110.0},
        {'Y', -0.1, true, 45396.6, std::nullopt, 55.5},
        {'Z', std::nullopt, false, std::nullopt, std::nullopt, std::nullopt},
    };
    s.busy = true;
    s.ttl_in0_mode = 1;
    s.ttl_out0_mode = 0;
    s.last_error =
        controller_error_info{-4, "parameter_out_of_range", "Parameter Out of Range", {}, at_ms(1000)};
    s.report = report_port_state::open;
    s.updated = at_ms(1795322740123);
    return s;
}

class bridge_test : public ::testing::Test {
  protected:
    bridge_test() {
        sink_->hub = hub_;
        sink_->id = hub_->add_subscriber(sink_);
        EXPECT_FALSE(hub_->subscribe(sink_->id, "#"));
        run();
    }
    void run() {
        ioc_.restart();
        ioc_.poll();
    }

    boost::asio::io_context ioc_;
    std::shared_ptr<gw::event_hub> hub_ = gw::event_hub::create(ioc_.get_executor());
    std::shared_ptr<collecting_sink> sink_ = std::make_shared<collecting_sink>();
    std::shared_ptr<gw::controller_state_texts> texts_ = std::make_shared<gw::controller_state_texts>();
    gw::controller_events_bridge bridge_{hub_, texts_};
};

TEST_F(bridge_test, the_state_text_is_kept_for_requests_and_is_the_events_text) {
    EXPECT_EQ(texts_->get("stage1"), nullptr);
    auto snapshot = connected_snapshot();
    bridge_.on_snapshot(snapshot);
    run();
    auto text = texts_->get("stage1");
    ASSERT_NE(text, nullptr);
    EXPECT_EQ(json::parse(*text), gw::state_json(snapshot));
    auto state = sink_->on("controllers/stage1/state");
    ASSERT_EQ(state.size(), 1u);
    EXPECT_EQ(state[0]->data, text) << "one text, shared by the event and the requests";

    // A newer snapshot replaces it; a new identification shows in it (the identity JSON is kept
    // only while the identity is the same).
    snapshot.updated += seconds(1);
    snapshot.identity->version = "9.60";
    bridge_.on_snapshot(snapshot);
    auto newer = json::parse(*texts_->get("stage1"));
    EXPECT_EQ(newer, gw::state_json(snapshot));
    EXPECT_EQ(newer["identity"]["version"], "9.60");
    snapshot.identity.reset();
    bridge_.on_snapshot(snapshot);
    EXPECT_EQ(json::parse(*texts_->get("stage1"))["identity"], nullptr);

    bridge_.forget("stage1");
    EXPECT_EQ(texts_->get("stage1"), nullptr);
}

TEST_F(bridge_test, snapshot_becomes_state_and_position) {
    bridge_.on_snapshot(connected_snapshot());
    run();
    auto state = sink_->on("controllers/stage1/state");
    auto position = sink_->on("controllers/stage1/position");
    ASSERT_EQ(state.size(), 1u);
    ASSERT_EQ(position.size(), 1u);
    EXPECT_EQ(state[0]->sequence, 1u);
    EXPECT_EQ(state[0]->time, at_ms(1795322740123));  // the snapshot's time, not the hub's

    auto s = json::parse(*state[0]->data);
    EXPECT_EQ(s["id"], "stage1");
    EXPECT_EQ(s["state"], "connected");
    EXPECT_EQ(s["port"], "/dev/ttyUSB0");
    EXPECT_EQ(s["busy"], true);
    EXPECT_EQ(s["identity"]["version"], "9.52");
    EXPECT_EQ(s["identity"]["build"], "STD_XYZ");
    EXPECT_EQ(s["identity"]["motor_axes"], "XYZ");
    EXPECT_EQ(s["identity"]["modules"], json({"array", "ring_buffer", "ttl_report"}));
    EXPECT_EQ(s["identity"]["ring_buffer_size"], 50);
    ASSERT_EQ(s["axes"].size(), 3u);
    EXPECT_EQ(s["axes"][0],
              json::parse(R"({"axis":"X","position_um":1234.5,"busy":false,"counts_per_mm":45396.6,
                                            "soft_limits_um":{"lower":-110000.0,"upper":110000.0}})"));
    EXPECT_EQ(s["axes"][1]["position_um"], -0.1);
    EXPECT_EQ(s["axes"][1]["soft_limits_um"]["lower"], nullptr);
    EXPECT_EQ(s["axes"][1]["soft_limits_um"]["upper"], 55500.0);
    EXPECT_EQ(s["axes"][2]["position_um"], nullptr);
    EXPECT_EQ(s["ttl"], json::parse(R"({"in0_mode":1,"out0_mode":0})"));
    EXPECT_EQ(s["last_error"], json::parse(R"({"code":-4,"name":"parameter_out_of_range","hint":null,
                                               "text":"Parameter Out of Range","time":"1970-01-01T00:00:01.000Z"})"));
    EXPECT_EQ(s["report_port"], "open");
    // Connected: no retry due; no attempt was recorded in this hand-made snapshot.
    EXPECT_EQ(s["last_attempt"], nullptr);
    EXPECT_EQ(s["next_retry"], nullptr);
    EXPECT_EQ(s["updated"], "2026-11-22T04:45:40.123Z");

    auto p = json::parse(*position[0]->data);
    EXPECT_EQ(p, json::parse(R"({"id":"stage1","busy":true,"axes":[
        {"axis":"X","position_um":1234.5,"busy":false},
        {"axis":"Y","position_um":-0.1,"busy":true},
        {"axis":"Z","position_um":null,"busy":false}]})"));
    // The whole message is what a WebSocket client receives.
    auto m = json::parse(*position[0]->message);
    EXPECT_EQ(m["topic"], "controllers/stage1/position");
    EXPECT_EQ(m["seq"], 1);
    EXPECT_EQ(m["time"], "2026-11-22T04:45:40.123Z");
    EXPECT_EQ(m["data"], p);
}

TEST_F(bridge_test, position_only_when_positions_or_busy_change) {
    // run() after each: state and position are latest-value topics and would coalesce otherwise.
    auto s = connected_snapshot();
    bridge_.on_snapshot(s);
    run();
    s.ttl_in0_mode = 5;  // state changes, positions do not
    bridge_.on_snapshot(s);
    run();
    s.axes[0].position_um = 1300.25;
    bridge_.on_snapshot(s);
    run();
    s.axes[1].busy = false;
    bridge_.on_snapshot(s);
    run();
    auto state = sink_->on("controllers/stage1/state");
    auto position = sink_->on("controllers/stage1/position");
    ASSERT_EQ(state.size(), 4u);
    ASSERT_EQ(position.size(), 3u);
    EXPECT_EQ(state[3]->sequence, 4u);
    EXPECT_EQ(position[2]->sequence, 3u);
    EXPECT_EQ(json::parse(*position[1]->data)["axes"][0]["position_um"], 1300.25);
    EXPECT_EQ(json::parse(*position[2]->data)["axes"][1]["busy"], false);

    // Another controller has its own topics and numbering.
    auto other = connected_snapshot();
    other.id = "stage2";
    bridge_.on_snapshot(other);
    run();
    ASSERT_EQ(sink_->on("controllers/stage2/position").size(), 1u);
    EXPECT_EQ(sink_->on("controllers/stage2/position")[0]->sequence, 1u);
}

TEST_F(bridge_test, position_time_is_when_the_positions_were_read) {
    // A "/" answer after a move changes only the busy flags: the position event it causes carries the
    // positions read earlier, and says so with their time, not the snapshot's newer one.
    auto s = connected_snapshot();
    s.positions_read = at_ms(1795322740000);
    bridge_.on_snapshot(s);
    run();
    s.busy = false;
    s.axes[1].busy = false;
    s.updated = at_ms(1795322740500);
    bridge_.on_snapshot(s);
    run();
    auto position = sink_->on("controllers/stage1/position");
    auto state = sink_->on("controllers/stage1/state");
    ASSERT_EQ(position.size(), 2u);
    EXPECT_EQ(position[0]->time, at_ms(1795322740000));
    EXPECT_EQ(position[1]->time, at_ms(1795322740000));
    EXPECT_EQ(json::parse(*position[1]->message)["time"], "2026-11-22T04:45:40.000Z");
    ASSERT_EQ(state.size(), 2u);
    EXPECT_EQ(state[1]->time, at_ms(1795322740500));
}

TEST_F(bridge_test, report_event_becomes_a_reports_event) {
    gw::devices::report_event r;
    r.controller_id = "stage1";
    r.sequence = 7;
    r.system_time = at_ms(1795322740456);
    r.axes = {{'X', 12345, 271.937}, {'Y', -20, std::nullopt}};
    r.bytes_skipped = 3;
    bridge_.on_report(r);
    r.sequence = 8;
    bridge_.on_report(r);
    run();
    auto events = sink_->on("controllers/stage1/reports");
    ASSERT_EQ(events.size(), 2u);
    EXPECT_EQ(events[0]->sequence, 1u);
    EXPECT_EQ(events[1]->sequence, 2u);
    EXPECT_EQ(events[0]->time, at_ms(1795322740456));
    EXPECT_EQ(json::parse(*events[0]->data), json::parse(R"({"id":"stage1","controller_seq":7,
        "time":"2026-11-22T04:45:40.456Z","bytes_skipped":3,
        "axes":[{"axis":"X","counts":12345,"position_um":271.937},
                {"axis":"Y","counts":-20,"position_um":null}]})"));
}

TEST_F(bridge_test, ttl_event_becomes_a_ttl_event) {
    gw::devices::ttl_event t;
    t.controller_id = "stage1";
    t.sequence = 3;
    t.system_time = at_ms(1795322740789);
    t.controller_ms = 400;
    t.axes = {{'X', 0.0}, {'Y', 0.1 + 0.2}};  // 0.30000000000000004 rounds to the nanometre
    bridge_.on_ttl(t);
    run();
    auto events = sink_->on("controllers/stage1/ttl");
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(
        *events[0]->data,
        R"({"axes":[{"axis":"X","position_um":0.0},{"axis":"Y","position_um":0.3}],"controller_ms":400.0,)"
        R"("controller_seq":3,"id":"stage1","time":"2026-11-22T04:45:40.789Z"})");
}

TEST_F(bridge_test, error_log_codes_become_an_errors_event_and_87s_a_notice_in_the_report_stream) {
    bridge_.on_error_log({"stage1", {35, 87, 87}, at_ms(1795322740789)});
    bridge_.on_error_log({"stage1", {34}, at_ms(1795322740790)});
    run();
    auto errors = sink_->on("controllers/stage1/errors");
    ASSERT_EQ(errors.size(), 2u);
    EXPECT_EQ(
        *errors[0]->data,
        R"({"codes":[{"code":35,"name":"LOWER_LIMIT"},{"code":87,"name":"TTL_REPORT_BUFFER_OVERRUN"},)"
        R"({"code":87,"name":"TTL_REPORT_BUFFER_OVERRUN"}],"id":"stage1","time":"2026-11-22T04:45:40.789Z"})");
    // Only the read with 87s puts a notice into the report stream.
    auto reports = sink_->on("controllers/stage1/reports");
    ASSERT_EQ(reports.size(), 1u);
    EXPECT_EQ(*reports[0]->data,
              R"({"controller_overruns":2,"id":"stage1","time":"2026-11-22T04:45:40.789Z"})");
    EXPECT_EQ(gw::report_overruns(*reports[0]->data), 2u);
}

TEST(event_json, report_overruns_reads_only_the_notice) {
    EXPECT_EQ(gw::report_overruns(R"({"controller_overruns":12,"id":"a","time":"t"})"), 12u);
    EXPECT_EQ(gw::report_overruns(R"({"axes":[],"bytes_skipped":0,"controller_seq":3,"id":"a"})"),
              std::nullopt);
    EXPECT_EQ(gw::report_overruns(R"({"controller_overruns":x})"), std::nullopt);
    EXPECT_EQ(gw::report_overruns(""), std::nullopt);
}

TEST(event_json, disconnected_controller_without_identity) {
    gw::devices::controller_snapshot s;
    s.id = "stage9";
    s.state = gw::devices::connection_state::disconnected;
    s.report = gw::devices::report_port_state::closed;
    auto j = gw::state_json(s);
    EXPECT_EQ(j["state"], "disconnected");
    EXPECT_EQ(j["identity"], nullptr);
    EXPECT_EQ(j["last_error"], nullptr);
    EXPECT_EQ(j["axes"], json::array());
    EXPECT_EQ(j["ttl"]["in0_mode"], nullptr);
    EXPECT_EQ(j["report_port"], "closed");
    EXPECT_EQ(gw::controller_topic("stage9", "state"), "controllers/stage9/state");
}

}  // namespace
