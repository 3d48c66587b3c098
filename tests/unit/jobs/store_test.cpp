#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sqlite3.h>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/common/job_id.hpp"
#include "gateway/jobs/job_json.hpp"
#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// A fresh directory per test, removed afterwards.
class store_test : public ::testing::Test {
  protected:
    void SetUp() override {
        std::string tmpl = (fs::temp_directory_path() / "gw-store-test-XXXXXX").string();
        ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }

    std::unique_ptr<job_store> open_store(job_store_options options = {}) {
        auto s = job_store::open(dir_.string(), options);
        EXPECT_TRUE(s) << (s ? "" : s.error().message);
        return s ? std::move(*s) : nullptr;
    }

    fs::path dir_;
};

job_clock::time_point at_ms(std::int64_t ms) {
    return job_clock::time_point(std::chrono::milliseconds(ms));
}

// Ids with a given creation order: the millisecond decides.
std::string id_at(std::int64_t ms, std::uint8_t salt = 0) {
    std::array<std::uint8_t, 10> r{};
    r[9] = salt;
    return format_job_id(static_cast<std::uint64_t>(ms), r);
}

job_record make_job(std::string id, std::string controller = "sim1", job_type type = job_type::array,
                    job_state state = job_state::queued) {
    job_record j;
    j.id = std::move(id);
    j.controller = std::move(controller);
    j.type = type;
    j.state = state;
    j.spec = {{"plate", "96"}, {"dwell_ms", 100}, {"wells", {"A1", "B2"}}};
    j.progress.steps_total = 96;
    j.estimated_s = 81.5;
    j.plan_path = "firmware";
    j.submitted_by = "alice";
    j.request_id = "req-1";
    j.created = at_ms(1'700'000'000'123);
    j.updated = j.created;
    return j;
}

void expect_same(const job_record& a, const job_record& b) {
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.controller, b.controller);
    EXPECT_EQ(a.type, b.type);
    EXPECT_EQ(a.spec, b.spec);
    EXPECT_EQ(a.state, b.state);
    EXPECT_EQ(a.progress.steps_done, b.progress.steps_done);
    EXPECT_EQ(a.progress.steps_total, b.progress.steps_total);
    EXPECT_EQ(a.progress.current_step, b.progress.current_step);
    EXPECT_EQ(a.progress.remaining_s, b.progress.remaining_s);
    EXPECT_EQ(a.estimated_s, b.estimated_s);
    EXPECT_EQ(a.plan_path, b.plan_path);
    EXPECT_EQ(a.idempotency_key, b.idempotency_key);
    EXPECT_EQ(a.submitted_by, b.submitted_by);
    EXPECT_EQ(a.request_id, b.request_id);
    EXPECT_EQ(a.reason, b.reason);
    EXPECT_EQ(a.created, b.created);
    EXPECT_EQ(a.started, b.started);
    EXPECT_EQ(a.finished, b.finished);
    EXPECT_EQ(a.updated, b.updated);
}

// storage.retention: ended jobs (only those) go by age and by count, with their events and transitions,
// in batches of at most `batch`.
TEST_F(store_test, delete_ended_removes_old_and_surplus_ended_jobs_with_their_history) {
    auto store = open_store();
    ASSERT_TRUE(store);
    const job_state states[] = {job_state::succeeded, job_state::failed,  job_state::cancelled,
                                job_state::succeeded, job_state::running, job_state::interrupted,
                                job_state::succeeded, job_state::queued,  job_state::paused};
    std::vector<std::string> ids;
    for (std::size_t i = 0; i < std::size(states); ++i) {
        auto j = make_job(id_at(1'700'000'000'000 + static_cast<std::int64_t>(i) * 1000));
        ASSERT_TRUE(store->insert(j, {{"type", "state"}}));
        j.state = states[i];
        if (is_terminal(j.state)) j.finished = at_ms(1'700'000'000'000 + static_cast<std::int64_t>(i) * 1000);
        ASSERT_TRUE(store->save(j, {{"type", "state"}, {"n", i}}));
        ids.push_back(j.id);
    }
    const auto present = [&](std::size_t i) { return store->find(ids[i])->has_value(); };
    // Nothing asked: nothing deleted.
    EXPECT_EQ(*store->delete_ended(std::nullopt, std::nullopt, 100), 0U);
    // By age: the ended jobs that finished before job 2's end (jobs 0 and 1), one batch of one at a time.
    EXPECT_EQ(*store->delete_ended(at_ms(1'700'000'002'000), std::nullopt, 1), 1U);
    EXPECT_EQ(*store->delete_ended(at_ms(1'700'000'002'000), std::nullopt, 1), 1U);
    EXPECT_EQ(*store->delete_ended(at_ms(1'700'000'002'000), std::nullopt, 1), 0U);
    EXPECT_FALSE(present(0));
    EXPECT_FALSE(present(1));
    EXPECT_TRUE(present(2));
    // Their history went with them.
    EXPECT_TRUE(store->events(ids[0], 100)->empty());
    EXPECT_TRUE(store->transitions(ids[0])->empty());
    // By count: the newest two ended jobs stay (6 and 3); 2 goes. Running, interrupted (it may be resumed),
    // queued and paused jobs are never deleted.
    EXPECT_EQ(*store->delete_ended(std::nullopt, 2, 100), 1U);
    for (std::size_t i : {2U})
        EXPECT_FALSE(present(i)) << i;
    for (std::size_t i : {3U, 4U, 5U, 6U, 7U, 8U})
        EXPECT_TRUE(present(i)) << i;
    EXPECT_EQ(store->events(ids[6], 100)->size(), 2U);
}

// A state event keeps what changes: its record's fixed fields are stored once, in the job's row, and
// put back when the events are read.
TEST_F(store_test, state_events_are_stored_without_the_fixed_fields_and_read_back_whole) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto j = make_job(id_at(1'700'000'000'000));
    j.idempotency_key = "plate-7";
    ASSERT_TRUE(store->insert(j, state_event(j, j.created)));
    j.state = job_state::running;
    j.started = at_ms(1'700'000'001'000);
    j.updated = *j.started;
    const auto running = state_event(j, j.updated);
    ASSERT_TRUE(store->save(j, running));
    ASSERT_TRUE(store->append_event(j.id, {{"type", "step"}, {"index", 0}}));

    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / job_store_file_name).string().c_str(), &db), SQLITE_OK);
    sqlite3_stmt* st = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "SELECT event FROM job_events WHERE seq = 2", -1, &st, nullptr),
              SQLITE_OK);
    ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
    const auto stored = nlohmann::json::parse(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)));
    sqlite3_finalize(st);
    sqlite3_close(db);
    for (const char* fixed :
         {"id", "controller", "type", "created", "submitted_by", "request_id", "idempotency_key"})
        EXPECT_FALSE(stored["job"].contains(fixed)) << fixed;
    EXPECT_EQ(stored["job"]["state"], "running");

    auto events = store->events(j.id, 10);
    ASSERT_TRUE(events);
    ASSERT_EQ(events->size(), 3U);
    EXPECT_EQ((*events)[1], running);  // whole again
    EXPECT_EQ((*events)[0]["job"]["idempotency_key"], "plate-7");
    EXPECT_EQ((*events)[2], (nlohmann::json{{"type", "step"}, {"index", 0}}));
}

TEST_F(store_test, creates_the_directory_and_the_database_file) {
    dir_ /= "nested/deeper";
    auto store = open_store();
    ASSERT_TRUE(store);
    EXPECT_TRUE(fs::exists(dir_ / "jobs.sqlite3"));
    EXPECT_EQ(store->path(), (dir_ / "jobs.sqlite3").string());
}

TEST_F(store_test, insert_then_find_round_trips_every_field) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto j = make_job(make_job_id());
    j.state = job_state::paused;
    j.progress = {.steps_done = 12,
                  .steps_total = 96,
                  .current_step = "B1",
                  .remaining_s = 70.25,
                  .waiting_for = job_wait::controller,
                  .eta = at_ms(1'700'000'072'000)};
    j.idempotency_key = "key-1";
    j.reason = "controller disconnected";
    j.started = at_ms(1'700'000'001'000);
    j.finished = at_ms(1'700'000'002'000);
    j.updated = at_ms(1'700'000'002'500);
    ASSERT_TRUE(store->insert(j));

    auto found = store->find(j.id);
    ASSERT_TRUE(found) << found.error().message;
    ASSERT_TRUE(found->has_value());
    expect_same(**found, j);
    // Live only: after a restart no job waits or runs.
    EXPECT_FALSE((*found)->progress.waiting_for);
    EXPECT_FALSE((*found)->progress.eta);

    auto missing = store->find("j-nope");
    ASSERT_TRUE(missing);
    EXPECT_FALSE(missing->has_value());
}

TEST_F(store_test, values_are_bound_not_spliced_into_sql) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto j = make_job(make_job_id(), "x'); DROP TABLE jobs; --");
    j.spec = {{"note", "it's \"quoted\" \u00e9"}};
    j.reason = "";
    j.request_id = "";
    ASSERT_TRUE(store->insert(j));
    auto found = store->find(j.id);
    ASSERT_TRUE(found && found->has_value());
    expect_same(**found, j);
    job_filter f;
    f.controller = j.controller;
    auto page = store->list(f);
    ASSERT_TRUE(page);
    ASSERT_EQ(page->jobs.size(), 1u);
}

TEST_F(store_test, save_writes_mutable_columns_and_records_transitions_on_state_change_only) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto j = make_job(make_job_id());
    ASSERT_TRUE(store->insert(j));

    j.state = job_state::running;
    j.started = at_ms(1'700'000'000'500);
    j.updated = *j.started;
    ASSERT_TRUE(store->save(j));
    j.progress.steps_done = 5;
    j.progress.current_step = "A5";
    j.progress.remaining_s.reset();
    j.updated = at_ms(1'700'000'000'900);
    ASSERT_TRUE(store->save(j));  // progress only: no transition
    j.state = job_state::failed;
    j.reason = "controller answered :N-3";
    j.finished = at_ms(1'700'000'001'000);
    j.updated = *j.finished;
    ASSERT_TRUE(store->save(j));

    auto found = store->find(j.id);
    ASSERT_TRUE(found && found->has_value());
    expect_same(**found, j);

    auto t = store->transitions(j.id);
    ASSERT_TRUE(t) << t.error().message;
    ASSERT_EQ(t->size(), 3u);
    EXPECT_TRUE((*t)[0]["from"].is_null());
    EXPECT_EQ((*t)[0]["to"], "queued");
    EXPECT_EQ((*t)[0]["at"], "2023-11-14T22:13:20.123Z");
    EXPECT_EQ((*t)[1]["from"], "queued");
    EXPECT_EQ((*t)[1]["to"], "running");
    EXPECT_EQ((*t)[1]["at"], "2023-11-14T22:13:20.500Z");
    EXPECT_EQ((*t)[2]["from"], "running");
    EXPECT_EQ((*t)[2]["to"], "failed");
    EXPECT_EQ((*t)[2]["reason"], "controller answered :N-3");
}

TEST_F(store_test, save_of_an_unknown_job_is_unknown_job) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto r = store->save(make_job(make_job_id()));
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::unknown_job);
}

TEST_F(store_test, duplicate_id_is_refused_and_changes_nothing) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto j = make_job(make_job_id());
    ASSERT_TRUE(store->insert(j));
    auto again = j;
    again.controller = "sim2";
    auto r = store->insert(again);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::invalid_state);
    EXPECT_NE(r.error().message.find(j.id), std::string::npos);
    auto found = store->find(j.id);
    ASSERT_TRUE(found && found->has_value());
    EXPECT_EQ((*found)->controller, "sim1");
    auto t = store->transitions(j.id);
    ASSERT_TRUE(t);
    EXPECT_EQ(t->size(), 1u);  // the refused insert's transition was rolled back
}

TEST_F(store_test, idempotency_key_lookup_and_unique_refusal) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto first = make_job(make_job_id());
    first.idempotency_key = "order-42";
    ASSERT_TRUE(store->insert(first));
    // Jobs without a key do not collide with each other.
    ASSERT_TRUE(store->insert(make_job(make_job_id())));
    ASSERT_TRUE(store->insert(make_job(make_job_id())));

    auto found = store->find_by_idempotency_key("order-42");
    ASSERT_TRUE(found && found->has_value());
    EXPECT_EQ((*found)->id, first.id);
    auto none = store->find_by_idempotency_key("order-43");
    ASSERT_TRUE(none);
    EXPECT_FALSE(none->has_value());

    auto second = make_job(make_job_id());
    second.idempotency_key = "order-42";
    auto r = store->insert(second);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::invalid_state);
    EXPECT_NE(r.error().message.find("order-42"), std::string::npos);
    auto gone = store->find(second.id);
    ASSERT_TRUE(gone);
    EXPECT_FALSE(gone->has_value());
}

TEST_F(store_test, events_are_kept_in_order_with_a_limit) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto a = make_job(make_job_id());
    auto b = make_job(make_job_id());
    ASSERT_TRUE(store->insert(a));
    ASSERT_TRUE(store->insert(b));
    for (int i = 0; i < 20; ++i) {
        ASSERT_TRUE(store->append_event(a.id, {{"type", "step"}, {"index", i}}));
        if (i % 2 == 0) {
            ASSERT_TRUE(store->append_event(b.id, {{"type", "step"}, {"index", 100 + i}}));
        }
    }
    auto ea = store->events(a.id, 1000);
    ASSERT_TRUE(ea) << ea.error().message;
    ASSERT_EQ(ea->size(), 20u);
    for (int i = 0; i < 20; ++i)
        EXPECT_EQ((*ea)[static_cast<std::size_t>(i)]["index"], i);
    auto eb = store->events(b.id, 3);
    ASSERT_TRUE(eb);
    ASSERT_EQ(eb->size(), 3u);
    EXPECT_EQ((*eb)[0]["index"], 100);
    EXPECT_EQ((*eb)[2]["index"], 104);
    auto none = store->events("j-unknown", 10);
    ASSERT_TRUE(none);
    EXPECT_TRUE(none->empty());
}

TEST_F(store_test, insert_stores_the_first_event_with_the_job_or_neither) {
    auto store = open_store({.max_size_mb = 1});
    ASSERT_TRUE(store);
    const auto id = make_job_id();
    const nlohmann::json queued = {{"type", "state"}, {"state", "queued"}};
    ASSERT_TRUE(store->insert(make_job(id), queued));
    ASSERT_TRUE(store->append_event(id, {{"type", "step"}, {"index", 0}}));
    auto e = store->events(id, 10);
    ASSERT_TRUE(e) << e.error().message;
    ASSERT_EQ(e->size(), 2u);
    EXPECT_EQ((*e)[0], queued);
    EXPECT_EQ((*e)[1].value("type", ""), "step");

    // A first event the store cannot take (larger than the 1 MB file may grow): no job either.
    const auto refused_id = make_job_id();
    const nlohmann::json huge = {{"type", "state"}, {"filler", std::string(2 * 1024 * 1024, 'x')}};
    auto r = store->insert(make_job(refused_id), huge);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(r.error().message.find("full"), std::string::npos) << r.error().message;
    auto found = store->find(refused_id);
    ASSERT_TRUE(found) << found.error().message;
    EXPECT_FALSE(found->has_value());
    auto transitions = store->transitions(refused_id);
    ASSERT_TRUE(transitions);
    EXPECT_TRUE(transitions->empty());
    auto events = store->events(refused_id, 10);
    ASSERT_TRUE(events);
    EXPECT_TRUE(events->empty());
}

TEST_F(store_test, save_stores_the_event_with_the_record_or_neither) {
    auto store = open_store({.max_size_mb = 1});
    ASSERT_TRUE(store);
    const auto id = make_job_id();
    auto j = make_job(id);
    ASSERT_TRUE(store->insert(j));
    j.state = job_state::running;
    j.progress.steps_done = 1;
    ASSERT_TRUE(store->save(j, {{"type", "step"}, {"index", 0}}));
    auto e = store->events(id, 10);
    ASSERT_TRUE(e);
    ASSERT_EQ(e->size(), 1u);
    EXPECT_EQ((*e)[0].value("index", -1), 0);

    // An event the store cannot take: the step's progress and the transition are not stored either.
    j.state = job_state::paused;
    j.progress.steps_done = 2;
    auto r = store->save(j, {{"type", "step"}, {"filler", std::string(2 * 1024 * 1024, 'x')}});
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    auto found = store->find(id);
    ASSERT_TRUE(found && found->has_value());
    EXPECT_EQ((*found)->state, job_state::running);
    EXPECT_EQ((*found)->progress.steps_done, 1u);
    auto transitions = store->transitions(id);
    ASSERT_TRUE(transitions);
    EXPECT_EQ(transitions->size(), 2u);  // queued, running
    e = store->events(id, 10);
    ASSERT_TRUE(e);
    EXPECT_EQ(e->size(), 1u);
}

TEST_F(store_test, an_event_of_an_unknown_job_is_refused) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto r = store->append_event("j-unknown", {{"type", "step"}});
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::unknown_job);
}

TEST_F(store_test, list_filters_and_pages_newest_first_without_duplicates_or_holes) {
    auto store = open_store();
    ASSERT_TRUE(store);
    const std::vector<std::string> controllers{"sim1", "sim2", "sim3"};
    const std::vector<job_type> types{job_type::array, job_type::scan, job_type::ring_buffer};
    const std::vector<job_state> states{job_state::queued, job_state::running, job_state::succeeded,
                                        job_state::cancelled};
    std::vector<job_record> all;
    for (int i = 0; i < 60; ++i) {
        auto j =
            make_job(id_at(1'700'000'000'000 + i * 7), controllers[static_cast<std::size_t>(i) % 3],
                     types[static_cast<std::size_t>(i / 3) % 3], states[static_cast<std::size_t>(i) % 4]);
        ASSERT_TRUE(store->insert(j));
        all.push_back(j);
    }
    std::reverse(all.begin(), all.end());  // newest first

    std::vector<job_filter> filters;
    for (int mask = 0; mask < 8; ++mask) {
        for (std::size_t k = 0; k < 3; ++k) {
            job_filter f;
            if (mask & 1) f.controller = controllers[k];
            if (mask & 2) f.type = types[(k + 1) % 3];
            if (mask & 4) f.state = states[k];
            filters.push_back(f);
        }
    }
    for (const auto& f : filters) {
        std::vector<std::string> expected;
        for (const auto& j : all)
            if ((!f.controller || j.controller == *f.controller) && (!f.type || j.type == *f.type) &&
                (!f.state || j.state == *f.state))
                expected.push_back(j.id);
        for (std::size_t limit : {1u, 4u, 7u, 500u}) {
            auto page_filter = f;
            page_filter.limit = limit;
            std::vector<std::string> got;
            for (int pages = 0; pages < 100; ++pages) {
                auto page = store->list(page_filter);
                ASSERT_TRUE(page) << page.error().message;
                ASSERT_LE(page->jobs.size(), limit);
                for (const auto& j : page->jobs) {
                    if (f.controller) {
                        EXPECT_EQ(j.controller, *f.controller);
                    }
                    got.push_back(j.id);
                }
                if (!page->next) break;
                EXPECT_EQ(*page->next, page->jobs.back().id);
                page_filter.before = page->next;
            }
            EXPECT_EQ(got, expected) << "limit " << limit;
        }
    }
}

TEST_F(store_test, list_limit_outside_1_to_500_is_invalid_value) {
    auto store = open_store();
    ASSERT_TRUE(store);
    for (std::size_t limit : {0u, 501u}) {
        job_filter f;
        f.limit = limit;
        auto r = store->list(f);
        ASSERT_FALSE(r);
        EXPECT_EQ(r.error().kind, operation_error_kind::invalid_value);
        EXPECT_EQ(r.error().field, "limit");
    }
    job_filter f;
    f.limit = 500;
    EXPECT_TRUE(store->list(f));
}

TEST_F(store_test, a_full_last_page_has_no_next_cursor) {
    auto store = open_store();
    ASSERT_TRUE(store);
    for (int i = 0; i < 4; ++i)
        ASSERT_TRUE(store->insert(make_job(id_at(1000 + i))));
    job_filter f;
    f.limit = 4;
    auto page = store->list(f);
    ASSERT_TRUE(page);
    EXPECT_EQ(page->jobs.size(), 4u);
    EXPECT_FALSE(page->next);
    f.limit = 3;
    page = store->list(f);
    ASSERT_TRUE(page);
    ASSERT_TRUE(page->next);
    EXPECT_EQ(*page->next, id_at(1001));
}

TEST_F(store_test, in_states_returns_matching_jobs_oldest_first) {
    auto store = open_store();
    ASSERT_TRUE(store);
    const job_state states[] = {job_state::running,   job_state::queued,  job_state::paused,
                                job_state::succeeded, job_state::running, job_state::interrupted};
    for (int i = 0; i < 6; ++i)
        ASSERT_TRUE(store->insert(make_job(id_at(5000 + i), "sim1", job_type::scan, states[i])));
    auto r = store->in_states({job_state::running, job_state::paused});
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_EQ(r->size(), 3u);
    EXPECT_EQ((*r)[0].id, id_at(5000));
    EXPECT_EQ((*r)[1].id, id_at(5002));
    EXPECT_EQ((*r)[2].id, id_at(5004));
    auto none = store->in_states({});
    ASSERT_TRUE(none);
    EXPECT_TRUE(none->empty());
}

TEST_F(store_test, reopening_keeps_jobs_transitions_and_events) {
    auto j = make_job(make_job_id());
    j.idempotency_key = "k";
    {
        auto store = open_store();
        ASSERT_TRUE(store);
        ASSERT_TRUE(store->insert(j));
        j.state = job_state::running;
        ASSERT_TRUE(store->save(j));
        ASSERT_TRUE(store->append_event(j.id, {{"type", "step"}, {"name", "A1"}}));
        ASSERT_TRUE(store->flush());
    }
    auto store = open_store();
    ASSERT_TRUE(store);
    auto found = store->find(j.id);
    ASSERT_TRUE(found && found->has_value());
    expect_same(**found, j);
    auto by_key = store->find_by_idempotency_key("k");
    ASSERT_TRUE(by_key && by_key->has_value());
    auto t = store->transitions(j.id);
    ASSERT_TRUE(t);
    EXPECT_EQ(t->size(), 2u);
    auto e = store->events(j.id, 10);
    ASSERT_TRUE(e);
    ASSERT_EQ(e->size(), 1u);
    EXPECT_EQ((*e)[0]["name"], "A1");
    // Event numbering continues after the reopen.
    ASSERT_TRUE(store->append_event(j.id, {{"type", "step"}, {"name", "A2"}}));
    e = store->events(j.id, 10);
    ASSERT_TRUE(e);
    ASSERT_EQ(e->size(), 2u);
    EXPECT_EQ((*e)[1]["name"], "A2");
}

// A child process writes and kills itself with SIGKILL: no destructor, no checkpoint, the WAL is left
// behind. Everything committed before the kill must be there after a reopen.
TEST_F(store_test, data_committed_before_a_kill_9_survives) {
    const auto id = make_job_id();
    pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        auto store = job_store::open(dir_.string());
        if (!store) _exit(3);
        auto j = make_job(id);
        if (!(*store)->insert(j)) _exit(4);
        j.state = job_state::running;
        j.progress.steps_done = 7;
        j.progress.current_step = "A7";
        if (!(*store)->save(j)) _exit(5);
        for (int i = 0; i < 7; ++i)
            if (!(*store)->append_event(id, {{"type", "step"}, {"index", i}})) _exit(6);
        kill(getpid(), SIGKILL);
        _exit(7);
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "child exited with " << WEXITSTATUS(status);
    EXPECT_EQ(WTERMSIG(status), SIGKILL);
    EXPECT_TRUE(fs::exists(dir_ / "jobs.sqlite3-wal"));

    auto store = open_store();
    ASSERT_TRUE(store);
    auto found = store->find(id);
    ASSERT_TRUE(found && found->has_value());
    EXPECT_EQ((*found)->state, job_state::running);
    EXPECT_EQ((*found)->progress.steps_done, 7u);
    EXPECT_EQ((*found)->progress.current_step, "A7");
    auto e = store->events(id, 100);
    ASSERT_TRUE(e);
    EXPECT_EQ(e->size(), 7u);
    auto running = store->in_states({job_state::running});
    ASSERT_TRUE(running);
    ASSERT_EQ(running->size(), 1u);
}

TEST_F(store_test, destroying_without_flush_keeps_everything) {
    const auto id = make_job_id();
    {
        auto store = open_store();
        ASSERT_TRUE(store);
        ASSERT_TRUE(store->insert(make_job(id)));
    }
    auto store = open_store();
    ASSERT_TRUE(store);
    auto found = store->find(id);
    ASSERT_TRUE(found && found->has_value());
}

TEST_F(store_test, disk_full_fails_the_write_cleanly_and_reads_still_work) {
    auto store = open_store({.max_size_mb = 1});
    ASSERT_TRUE(store);
    const std::string filler(20 * 1024, 'x');
    std::vector<std::string> stored;
    operation_result<void> r;
    std::string failed_id;
    for (int i = 0; i < 200; ++i) {
        auto j = make_job(make_job_id());
        j.spec = {{"filler", filler}};
        r = store->insert(j);
        if (!r) {
            failed_id = j.id;
            break;
        }
        stored.push_back(j.id);
    }
    ASSERT_FALSE(r) << "1 MB never filled up";
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(r.error().message.find("full"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find(store->path()), std::string::npos) << r.error().message;
    ASSERT_FALSE(stored.empty());

    // The failed insert left nothing behind; what was there is readable.
    auto gone = store->find(failed_id);
    ASSERT_TRUE(gone) << gone.error().message;
    EXPECT_FALSE(gone->has_value());
    auto first = store->find(stored.front());
    ASSERT_TRUE(first && first->has_value());
    job_filter f;
    f.limit = 500;
    auto page = store->list(f);
    ASSERT_TRUE(page) << page.error().message;
    EXPECT_EQ(page->jobs.size(), stored.size());
    // Still full for another large write, and still no crash.
    auto j = make_job(make_job_id());
    j.spec = {{"filler", filler}};
    auto again = store->insert(j);
    ASSERT_FALSE(again);
    EXPECT_EQ(again.error().kind, operation_error_kind::storage_unavailable);
}

TEST_F(store_test, a_directory_that_cannot_exist_is_a_clear_open_error) {
    auto file = dir_ / "plain-file";
    std::ofstream(file) << "not a directory";
    auto r = job_store::open((file / "data").string());
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(r.error().message.find((file / "data").string()), std::string::npos) << r.error().message;

    auto empty = job_store::open("");
    ASSERT_FALSE(empty);
    EXPECT_EQ(empty.error().kind, operation_error_kind::storage_unavailable);
}

TEST_F(store_test, a_file_that_is_not_sqlite_is_a_clear_open_error) {
    std::ofstream(dir_ / "jobs.sqlite3") << std::string(8192, 'j') << "this is not a database\n";
    auto r = job_store::open(dir_.string());
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(r.error().message.find("not a database"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("jobs.sqlite3"), std::string::npos) << r.error().message;
}

TEST_F(store_test, a_schema_version_from_the_future_is_refused) {
    {
        auto store = open_store();
        ASSERT_TRUE(store);
        ASSERT_TRUE(store->insert(make_job(make_job_id())));
    }
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / "jobs.sqlite3").c_str(), &db), SQLITE_OK);
    const auto future = std::to_string(job_store_schema_version + 1);
    const auto set_version = "PRAGMA user_version = " + future;
    ASSERT_EQ(sqlite3_exec(db, set_version.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);

    auto r = job_store::open(dir_.string());
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(r.error().message.find("schema version " + future), std::string::npos) << r.error().message;
}

TEST_F(store_test, the_schema_version_is_the_current_one) {
    { ASSERT_TRUE(open_store()); }
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / "jobs.sqlite3").c_str(), &db), SQLITE_OK);
    sqlite3_stmt* s = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &s, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    EXPECT_EQ(sqlite3_column_int(s, 0), job_store_schema_version);
    sqlite3_finalize(s);
    ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &s, nullptr), SQLITE_OK);
    ASSERT_EQ(sqlite3_step(s), SQLITE_ROW);
    EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(s, 0)), "wal");
    sqlite3_finalize(s);
    sqlite3_close(db);
}

// A database file the process may not write. Root ignores file modes, so as root a child process
// drops to the "nobody" user first; the file and its directory stay root's. The result comes back
// through a pipe: "open: <error>", "insert: <error>" or "wrote".
TEST_F(store_test, a_read_only_database_is_a_clear_error_not_a_crash) {
    {
        auto store = open_store();
        ASSERT_TRUE(store);
        ASSERT_TRUE(store->insert(make_job(make_job_id())));
        ASSERT_TRUE(store->flush());
    }
    using p = fs::perms;
    fs::permissions(dir_, p::owner_all | p::group_read | p::group_exec | p::others_read | p::others_exec);
    fs::permissions(dir_ / "jobs.sqlite3", p::owner_read | p::group_read | p::others_read);

    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        close(fds[0]);
        auto say = [&](const std::string& text, int code) {
            auto n = write(fds[1], text.data(), text.size());
            _exit(n < 0 ? 9 : code);
        };
        if (geteuid() == 0 && (setgid(65534) != 0 || setuid(65534) != 0)) say("no nobody user", 2);
        auto r = job_store::open(dir_.string());
        if (!r)
            say((r.error().kind == operation_error_kind::storage_unavailable ? "open: " : "bad kind: ") +
                    r.error().message,
                0);
        auto w = (*r)->insert(make_job(make_job_id()));
        if (!w)
            say((w.error().kind == operation_error_kind::storage_unavailable ? "insert: " : "bad kind: ") +
                    w.error().message,
                0);
        say("wrote", 1);
    }
    close(fds[1]);
    std::string said;
    char buf[512];
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;)
        said.append(buf, static_cast<std::size_t>(n));
    close(fds[0]);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status)) << "child crashed; said " << said;
    if (WEXITSTATUS(status) == 2) GTEST_SKIP() << said;
    EXPECT_EQ(WEXITSTATUS(status), 0) << said;
    EXPECT_TRUE(said.starts_with("open: ") || said.starts_with("insert: ")) << said;
    EXPECT_NE(said.find("jobs.sqlite3"), std::string::npos) << said;
    std::cout << "read-only database: " << said << "\n";

    // The owner still reads everything.
    fs::permissions(dir_ / "jobs.sqlite3", p::owner_read | p::owner_write);
    auto store = open_store();
    ASSERT_TRUE(store);
    job_filter f;
    auto page = store->list(f);
    ASSERT_TRUE(page);
    EXPECT_EQ(page->jobs.size(), 1u);
}

// The job manager writes on its own thread while I/O threads read: a read must not wait for a write
// that waits for the disk or for a lock. Here another connection holds the write lock, so the store's
// write waits (busy_timeout); a read meanwhile answers with what is committed.
TEST_F(store_test, a_read_does_not_wait_for_a_write_in_progress) {
    job_store_options options;
    options.busy_timeout = 20s;
    auto store = open_store(options);
    ASSERT_TRUE(store);
    auto job = make_job(make_job_id());
    ASSERT_TRUE(store->insert(job));

    sqlite3* other = nullptr;
    ASSERT_EQ(sqlite3_open((dir_ / "jobs.sqlite3").c_str(), &other), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(other, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), SQLITE_OK);

    std::atomic<bool> write_returned{false};
    std::thread writer([&] {
        auto step = job;
        step.progress.steps_done = 1;
        EXPECT_TRUE(store->save(step, {{"type", "step"}}));
        write_returned = true;
    });
    // Gives the writer time to reach the lock; the assertions hold however far it got.
    std::this_thread::sleep_for(300ms);
    auto found = store->find(job.id);
    auto page = store->list(job_filter{});
    auto events = store->events(job.id, 10);
    EXPECT_FALSE(write_returned) << "the write did not wait for the other connection's lock";
    ASSERT_TRUE(found && *found) << (found ? "not found" : found.error().message);
    EXPECT_EQ((*found)->progress.steps_done, 0u);
    ASSERT_TRUE(page);
    EXPECT_EQ(page->jobs.size(), 1u);
    ASSERT_TRUE(events);
    EXPECT_TRUE(events->empty());

    ASSERT_EQ(sqlite3_exec(other, "ROLLBACK", nullptr, nullptr, nullptr), SQLITE_OK);
    writer.join();
    sqlite3_close(other);
    // The reader sees the write once it is committed.
    auto after = store->find(job.id);
    ASSERT_TRUE(after && *after);
    EXPECT_EQ((*after)->progress.steps_done, 1u);
    auto events_after = store->events(job.id, 10);
    ASSERT_TRUE(events_after);
    EXPECT_EQ(events_after->size(), 1u);
}

TEST_F(store_test, concurrent_callers_are_serialised) {
    auto store = open_store();
    ASSERT_TRUE(store);
    std::atomic<int> failures{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t) {
        threads.emplace_back([&] {
            for (int i = 0; i < 25; ++i) {
                auto j = make_job(make_job_id());
                if (!store->insert(j) || !store->append_event(j.id, {{"type", "step"}})) ++failures;
                job_filter f;
                f.limit = 10;
                if (!store->list(f)) ++failures;
            }
        });
    }
    for (auto& th : threads)
        th.join();
    EXPECT_EQ(failures.load(), 0);
    job_filter f;
    f.limit = 500;
    auto page = store->list(f);
    ASSERT_TRUE(page);
    EXPECT_EQ(page->jobs.size(), 100u);
}

TEST_F(store_test, two_stores_on_one_directory_see_each_others_writes) {
    auto a = open_store();
    auto b = open_store();
    ASSERT_TRUE(a && b);
    auto j = make_job(make_job_id());
    ASSERT_TRUE(a->insert(j));
    auto found = b->find(j.id);
    ASSERT_TRUE(found && found->has_value());
}

}  // namespace
}  // namespace gw::jobs
