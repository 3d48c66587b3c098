// The recorder against in-process simulators on real ptys: the report port's frames of triggered
// pulses, counted from 0 and stored in a real SQLite file, read back through the recorder.
#include "gateway/recordings/recorder.hpp"

#include <filesystem>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/use_future.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "devices/sim/sim_config.hpp"
#include "devices/sim/simulator.hpp"
#include "gateway/controllers/controller_registry.hpp"
#include "gateway/recordings/recording_store.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/sim_controller_settings.hpp"

namespace gw::recordings {
namespace {

namespace net = boost::asio;
namespace sim = devices::sim;
using namespace std::chrono_literals;
using kind = operation_error_kind;
using test::await;
using test::io_thread;

// The answer of a recorder call, waited for: `call` is given the handler.
template <typename T, typename Call>
operation_result<T> answer(Call call) {
    auto done = std::make_shared<std::promise<operation_result<T>>>();
    auto f = done->get_future();
    call([done](operation_result<T> r) { done->set_value(std::move(r)); });
    return await(std::move(f));
}

class recorder_test : public ::testing::Test {
  protected:
    // time_scale 1: a pulse train runs at its real rate, as a camera's triggers would.
    std::shared_ptr<sim::simulator> add_sim(const std::string& id, const std::string& preset) {
        auto config = sim::preset(preset).value();
        config.name = id;
        config.time_scale = 1;
        config.link_path = dir_ + "/" + id + "/port";
        config.report_link_path = dir_ + "/" + id + "/report";
        auto s = std::make_shared<sim::simulator>(sim_io_.io.get_executor(), config);
        s->start();
        sims_[id] = s;
        options_.controllers.push_back(gw::test::sim_controller_settings(id, *s, config.baud));
        return s;
    }

    void start() {
        registry_ = std::make_unique<controller_registry>(gw_io_.io.get_executor(), options_);
        registry_->start();
        ASSERT_TRUE(wait_until([&] { return registry_->ready(); })) << "controllers not ready";
        open_recorder();
    }

    void open_recorder() {
        recorder_settings s;
        s.storage_path = dir_ + "/store";
        s.flush_interval = 50ms;
        s.max_mb = max_mb_;
        auto r = recorder::open(gw_io_.io.get_executor(), *registry_, s);
        ASSERT_TRUE(r) << r.error().message;
        recorder_ = *r;
    }

    template <typename Pred>
    bool wait_until(Pred pred, std::chrono::milliseconds timeout = 30s) {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        while (std::chrono::steady_clock::now() < deadline) {
            if (pred()) return true;
            std::this_thread::sleep_for(10ms);
        }
        return pred();
    }

    operation_result<recording_record> start_recording(recording_request r) {
        return answer<recording_record>([&](auto h) { recorder_->start(std::move(r), std::move(h)); });
    }
    operation_result<recording_record> get(const std::string& id) {
        return answer<recording_record>([&](auto h) { recorder_->get(id, std::move(h)); });
    }
    operation_result<recording_record> stop(const std::string& id) {
        return answer<recording_record>([&](auto h) { recorder_->stop(id, std::move(h)); });
    }
    operation_result<bool> remove(const std::string& id) {
        return answer<bool>([&](auto h) { recorder_->remove(id, std::move(h)); });
    }
    // Every row of a recording, read back page by page as an export would.
    std::vector<recorded_frame> all_rows(const std::string& id) {
        std::vector<recorded_frame> out;
        std::int64_t from = 0;
        for (;;) {
            auto page = answer<frame_page>([&](auto h) { recorder_->rows(id, from, 300, std::move(h)); });
            EXPECT_TRUE(page) << (page ? "" : page.error().message);
            if (!page) return out;
            out.insert(out.end(), page->rows.begin(), page->rows.end());
            if (!page->next) return out;
            from = *page->next;
        }
    }
    int in0_mode(const std::string& id) {
        const auto state = nlohmann::json::parse(sims_[id]->state_json());
        return state.contains("ttl") ? state["ttl"].value("in0_mode", -1) : -1;
    }

    void TearDown() override {
        if (recorder_) {
            std::promise<void> done;
            recorder_->shutdown([&done] { done.set_value(); });
            EXPECT_EQ(done.get_future().wait_for(30s), std::future_status::ready);
        }
        if (registry_) registry_->stop();
        gw_io_.join();
        recorder_.reset();
        registry_.reset();
        for (auto& [id, s] : sims_)
            s->stop();
        sim_io_.join();
        std::filesystem::remove_all(dir_);
    }

    io_thread sim_io_;
    io_thread gw_io_;
    std::string dir_ = "/tmp/gw-recorder-" +
                       std::string(testing::UnitTest::GetInstance()->current_test_info()->name()) + "-" +
                       std::to_string(::getpid());
    registry_options options_;
    std::size_t max_mb_ = 0;
    std::map<std::string, std::shared_ptr<sim::simulator>> sims_;
    std::unique_ptr<controller_registry> registry_;
    std::shared_ptr<recorder> recorder_;
};

TEST_F(recorder_test, every_trigger_is_a_frame_counted_from_zero_at_the_stage_position) {
    auto s = add_sim("cam1", "full");
    start();
    move_request to{move_request::mode::absolute, {{'X', 1234.5}, {'Y', -250}}, true};
    ASSERT_TRUE(await(registry_->async_move("cam1", to, "test", net::use_future)));
    const int before = in0_mode("cam1");

    recording_request r;
    r.controller = "cam1";
    r.name = "plate 7";
    r.metadata = {{"objective", "20x"}};
    auto started = start_recording(r);
    ASSERT_TRUE(started) << started.error().message;
    EXPECT_EQ(started->state, recording_state::recording);
    EXPECT_EQ(started->previous_in_mode, before);
    EXPECT_EQ(in0_mode("cam1"), 1);  // armed: each IN0 edge makes a report

    constexpr int triggers = 1000;
    s->ttl_pulse_train(triggers, 500);
    ASSERT_TRUE(wait_until([&] {
        auto g = get(started->id);
        return g && g->frames >= triggers;
    })) << "frames stored: "
        << get(started->id)->frames;

    auto stopped = stop(started->id);
    ASSERT_TRUE(stopped) << stopped.error().message;
    EXPECT_EQ(stopped->state, recording_state::stopped);
    EXPECT_EQ(in0_mode("cam1"), before);  // the input mode put back

    const auto record = get(started->id);
    ASSERT_TRUE(record);
    EXPECT_EQ(record->frames, triggers);
    EXPECT_EQ(record->losses, 0u);
    EXPECT_EQ(record->name, "plate 7");
    EXPECT_EQ(record->metadata["objective"], "20x");
    ASSERT_GE(record->axes.size(), 2u);
    EXPECT_EQ(record->axes.substr(0, 2), "XY");

    const auto rows = all_rows(started->id);
    ASSERT_EQ(rows.size(), static_cast<std::size_t>(triggers));
    for (std::size_t i = 0; i < rows.size(); ++i) {
        ASSERT_EQ(rows[i].index, i);
        ASSERT_EQ(rows[i].loss, loss_kind::none);
        ASSERT_EQ(rows[i].um.size(), record->axes.size());
        ASSERT_TRUE(rows[i].um[0] && rows[i].um[1]) << "row " << i;
        EXPECT_NEAR(*rows[i].um[0], 1234.5, 0.5) << "row " << i;
        EXPECT_NEAR(*rows[i].um[1], -250, 0.5) << "row " << i;
        if (i > 0) {
            EXPECT_GE(rows[i].time_us, rows[i - 1].time_us);
        }
    }
}

TEST_F(recorder_test, max_frames_ends_it_and_puts_the_input_back) {
    auto s = add_sim("cam1", "full");
    start();
    const int before = in0_mode("cam1");
    recording_request r;
    r.controller = "cam1";
    r.name = "short";
    r.max_frames = 40;
    r.ttl_in_mode = 2;
    auto started = start_recording(r);
    ASSERT_TRUE(started) << started.error().message;
    EXPECT_EQ(in0_mode("cam1"), 2);
    s->ttl_pulse_train(100, 500);
    ASSERT_TRUE(wait_until([&] {
        auto g = get(started->id);
        return g && g->state == recording_state::stopped;
    }));
    const auto record = get(started->id);
    EXPECT_EQ(record->frames, 40u);
    EXPECT_NE(record->reason.find("max_frames"), std::string::npos) << record->reason;
    EXPECT_EQ(all_rows(started->id).size(), 40u);
    EXPECT_TRUE(wait_until([&] { return in0_mode("cam1") == before; }));
}

TEST_F(recorder_test, an_unplug_is_marked_as_a_loss_and_counting_goes_on) {
    auto s = add_sim("cam1", "full");
    start();
    recording_request r;
    r.controller = "cam1";
    r.name = "unplugged";
    auto started = start_recording(r);
    ASSERT_TRUE(started) << started.error().message;
    s->ttl_pulse_train(20, 500);
    ASSERT_TRUE(wait_until([&] { return get(started->id)->frames >= 20; }));
    s->unplug();
    ASSERT_TRUE(wait_until([&] { return get(started->id)->losses >= 1; }));
    s->replug();
    ASSERT_TRUE(wait_until([&] {
        auto c = registry_->get("cam1");
        return c && c->state == devices::connection_state::connected;
    }));
    s->ttl_pulse_train(10, 500);
    ASSERT_TRUE(wait_until([&] { return get(started->id)->frames >= 30; }));
    const auto rows = all_rows(started->id);
    ASSERT_EQ(rows.size(), 31u);  // 30 frames and the marker between them
    EXPECT_EQ(rows[20].loss, loss_kind::disconnected);
    EXPECT_EQ(rows[20].index, 20u);  // the frames lost (unknown) came before frame 20
    EXPECT_EQ(rows[21].index, 20u);
    EXPECT_EQ(rows[30].index, 29u);
}

TEST_F(recorder_test, a_controller_without_a_report_port_or_a_second_recording_is_refused) {
    add_sim("cam1", "full");
    add_sim("bare", "plain");  // no TTL_REPORT module, no report port
    start();
    recording_request r;
    r.controller = "bare";
    r.name = "x";
    const auto no_port = start_recording(r);
    ASSERT_FALSE(no_port);
    EXPECT_EQ(no_port.error().kind, kind::invalid_state);
    EXPECT_NE(no_port.error().message.find("report port"), std::string::npos) << no_port.error().message;
    r.controller = "cam1";
    r.name = "";
    EXPECT_EQ(start_recording(r).error().kind, kind::invalid_value);
    r.name = "x";
    r.ttl_in_mode = 0;
    EXPECT_EQ(start_recording(r).error().field, "arm.ttl_in_mode");
    r.ttl_in_mode = 1;
    r.controller = "nope";
    EXPECT_EQ(start_recording(r).error().kind, kind::unknown_controller);
    r.controller = "cam1";
    auto first = start_recording(r);
    ASSERT_TRUE(first);
    EXPECT_EQ(start_recording(r).error().kind, kind::busy);
    EXPECT_EQ(remove(first->id).error().kind, kind::invalid_state);
    ASSERT_TRUE(stop(first->id));
    EXPECT_TRUE(*remove(first->id));
    EXPECT_EQ(get(first->id).error().kind, kind::unknown_recording);
}

TEST_F(recorder_test, a_recording_the_gateway_did_not_end_is_failed_at_the_next_start) {
    auto s = add_sim("cam1", "full");
    start();
    recording_request r;
    r.controller = "cam1";
    r.name = "crash";
    const int before = in0_mode("cam1");
    auto started = start_recording(r);
    ASSERT_TRUE(started);
    s->ttl_pulse_train(30, 500);
    ASSERT_TRUE(wait_until([&] { return get(started->id)->frames >= 30; }));
    recorder_->abandon();  // gone without a shutdown, as a crash leaves it
    recorder_.reset();
    EXPECT_EQ(in0_mode("cam1"), 1);  // still armed
    open_recorder();
    const auto record = get(started->id);
    ASSERT_TRUE(record);
    EXPECT_EQ(record->state, recording_state::failed);
    EXPECT_NE(record->reason.find("unknown"), std::string::npos) << record->reason;
    EXPECT_EQ(all_rows(started->id).size(), record->frames + record->losses);
    // The input the crashed recording armed is put back as it was before it.
    EXPECT_TRUE(wait_until([&] { return in0_mode("cam1") == before; })) << "TTL X=" << in0_mode("cam1");
    auto next = start_recording(r);
    ASSERT_TRUE(next);
    EXPECT_EQ(next->previous_in_mode, before);
}

TEST_F(recorder_test,
       a_full_store_fails_the_recording_with_the_reason_and_refuses_new_ones_until_room_is_made) {
    // A 1 MB bound, nearly reached by an old recording written straight into the file.
    max_mb_ = 1;
    {
        auto store = recording_store::open(dir_ + "/store", max_mb_);
        ASSERT_TRUE(store) << store.error();
        recording_record old;
        old.id = "r-old";
        old.controller = "cam1";
        old.name = "old";
        old.state = recording_state::stopped;
        ASSERT_TRUE((*store)->create(old));
        std::vector<recorded_frame> page(500);
        for (int n = 0; (*store)->append(old, page); ++n) {
            ASSERT_LT(n, 1000) << "the bound never stopped the appends";
            for (auto& f : page) {
                f.index = old.frames++;
                f.counts = {1, 2, 3};
                f.um = {0.1, 0.2, 0.3};
            }
        }
        EXPECT_TRUE((*store)->last_write_was_full());
    }
    auto s = add_sim("cam1", "full");
    start();
    recording_request r;
    r.controller = "cam1";
    r.name = "too much";
    auto started = start_recording(r);
    ASSERT_TRUE(started) << started.error().message;
    s->ttl_pulse_train(600, 500);
    ASSERT_TRUE(wait_until([&] {
        auto g = get(started->id);
        return g && g->state != recording_state::recording;
    })) << "the recording went on with a full store";
    auto failed = get(started->id);
    EXPECT_EQ(failed->state, recording_state::failed);
    EXPECT_NE(failed->reason.find("recordings_max_mb"), std::string::npos) << failed->reason;
    // What it counts is what is stored: its download holds every row it says it has.
    EXPECT_EQ(all_rows(started->id).size(), failed->frames + failed->losses);
    EXPECT_EQ(in0_mode("cam1"), 0);  // the input put back all the same

    auto refused = start_recording(r);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().kind, kind::storage_unavailable);
    ASSERT_TRUE(remove("r-old"));
    auto again = start_recording(r);
    EXPECT_TRUE(again) << again.error().message;
}

}  // namespace
}  // namespace gw::recordings
