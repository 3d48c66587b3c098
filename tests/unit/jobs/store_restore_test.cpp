// The job store's restore commands (job_context::restore_if_stopped, kept across a crash) and the
// migration of a version 1 database, which has no table for them. Real SQLite files.
#include <cstdlib>
#include <filesystem>
#include <sqlite3.h>
#include <string>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/common/job_id.hpp"
#include "gateway/jobs/store/job_store.hpp"

namespace gw::jobs {
namespace {

namespace fs = std::filesystem;
using commands = std::vector<std::string>;

class store_restore_test : public ::testing::Test {
  protected:
    void SetUp() override {
        std::string tmpl = (fs::temp_directory_path() / "gw-store-restore-XXXXXX").string();
        ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }

    std::unique_ptr<job_store> open_store() {
        auto s = job_store::open(dir_.string());
        EXPECT_TRUE(s) << (s ? "" : s.error().message);
        return s ? std::move(*s) : nullptr;
    }

    // Runs SQL on the database file with a connection of its own (not the store's).
    void exec(const std::string& sql) {
        sqlite3* db = nullptr;
        ASSERT_EQ(sqlite3_open((dir_ / job_store_file_name).c_str(), &db), SQLITE_OK);
        char* error = nullptr;
        const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
        EXPECT_EQ(rc, SQLITE_OK) << (error ? error : "");
        sqlite3_free(error);
        sqlite3_close(db);
    }

    std::int64_t integer(const std::string& sql) {
        sqlite3* db = nullptr;
        EXPECT_EQ(sqlite3_open((dir_ / job_store_file_name).c_str(), &db), SQLITE_OK);
        sqlite3_stmt* s = nullptr;
        EXPECT_EQ(sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr), SQLITE_OK) << sqlite3_errmsg(db);
        std::int64_t v = -1;
        if (sqlite3_step(s) == SQLITE_ROW) v = sqlite3_column_int64(s, 0);
        sqlite3_finalize(s);
        sqlite3_close(db);
        return v;
    }

    fs::path dir_;
};

job_record make_restorable_job(std::string id) {
    job_record j;
    j.id = std::move(id);
    j.controller = "sim1";
    j.type = job_type::array;
    j.state = job_state::running;
    j.spec = {{"plate", "96"}};
    j.progress.steps_total = 96;
    j.estimated_s = 10;
    j.plan_path = "firmware";
    j.submitted_by = "alice";
    j.request_id = "req-1";
    j.created = job_clock::now();
    j.updated = j.created;
    return j;
}

commands stored(const job_store& store, const std::string& id) {
    auto r = store.restore_commands(id);
    EXPECT_TRUE(r) << (r ? "" : r.error().message);
    return r ? *r : commands{"<error>"};
}

TEST_F(store_restore_test, restore_commands_round_trip_in_order_replace_and_clear) {
    auto store = open_store();
    ASSERT_TRUE(store);
    const auto a = make_job_id();
    const auto b = make_job_id();
    ASSERT_TRUE(store->insert(make_restorable_job(a)));
    ASSERT_TRUE(store->insert(make_restorable_job(b)));
    EXPECT_EQ(stored(*store, a), commands{});  // nothing registered yet

    ASSERT_TRUE(store->set_restore_commands(a, {"TTL X=0"}));
    ASSERT_TRUE(store->set_restore_commands(b, {"S X=5.7"}));
    // The whole list each time: registration order is kept, the older list replaced.
    const commands two{"TTL X=0", "S X=5.7 Y=5.7", "quote ' and \" and ; DROP TABLE jobs;"};
    ASSERT_TRUE(store->set_restore_commands(a, two));
    EXPECT_EQ(stored(*store, a), two);
    EXPECT_EQ(stored(*store, b), commands{"S X=5.7"});  // the other job's list is its own

    ASSERT_TRUE(store->set_restore_commands(a, {}));
    EXPECT_EQ(stored(*store, a), commands{});
    EXPECT_EQ(integer("SELECT COUNT(*) FROM job_restore_commands"), 1);  // cleared means no row
    ASSERT_TRUE(store->set_restore_commands(a, {}));                     // clearing twice is fine
}

TEST_F(store_restore_test, restore_commands_survive_reopening) {
    const auto id = make_job_id();
    {
        auto store = open_store();
        ASSERT_TRUE(store);
        ASSERT_TRUE(store->insert(make_restorable_job(id)));
        ASSERT_TRUE(store->set_restore_commands(id, {"TTL X=7", "S X=1"}));
    }  // no flush: like a kill -9 after the call returned
    auto store = open_store();
    ASSERT_TRUE(store);
    EXPECT_EQ(stored(*store, id), (commands{"TTL X=7", "S X=1"}));
}

TEST_F(store_restore_test, restore_commands_of_an_unknown_job_are_refused) {
    auto store = open_store();
    ASSERT_TRUE(store);
    auto r = store->set_restore_commands("nope", {"TTL X=0"});
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::unknown_job);
    EXPECT_EQ(stored(*store, "nope"), commands{});
    EXPECT_EQ(integer("SELECT COUNT(*) FROM job_restore_commands"), 0);
}

TEST_F(store_restore_test, a_corrupt_list_is_a_storage_error_not_a_crash) {
    const auto id = make_job_id();
    auto store = open_store();
    ASSERT_TRUE(store);
    ASSERT_TRUE(store->insert(make_restorable_job(id)));
    exec("INSERT INTO job_restore_commands (job_id, commands, updated_ms) VALUES ('" + id +
         "', '[1, 2]', 0)");
    auto r = store->restore_commands(id);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::storage_unavailable);
    EXPECT_NE(r.error().message.find(id), std::string::npos) << r.error().message;
    ASSERT_TRUE(store->set_restore_commands(id, {"TTL X=0"}));  // a new list replaces it
    EXPECT_EQ(stored(*store, id), commands{"TTL X=0"});
}

// A database written by a gateway of schema version 1: the same file without the
// job_restore_commands table. Opening it migrates it in place and keeps every job.
TEST_F(store_restore_test, a_version_1_database_is_migrated_and_keeps_its_jobs) {
    const auto id = make_job_id();
    {
        auto store = open_store();
        ASSERT_TRUE(store);
        ASSERT_TRUE(store->insert(make_restorable_job(id)));
        ASSERT_TRUE(store->append_event(id, {{"type", "step"}, {"index", 0}}));
    }
    exec("DROP TABLE job_restore_commands; PRAGMA user_version = 1;");
    ASSERT_EQ(integer("PRAGMA user_version"), 1);
    ASSERT_EQ(integer("SELECT COUNT(*) FROM sqlite_master WHERE name = 'job_restore_commands'"), 0);

    auto store = open_store();
    ASSERT_TRUE(store);
    EXPECT_EQ(integer("PRAGMA user_version"), job_store_schema_version);
    EXPECT_EQ(integer("SELECT COUNT(*) FROM sqlite_master WHERE name = 'job_restore_commands'"), 1);
    auto found = store->find(id);
    ASSERT_TRUE(found && *found);
    EXPECT_EQ((*found)->state, job_state::running);
    auto events = store->events(id, 10);
    ASSERT_TRUE(events);
    EXPECT_EQ(events->size(), 1u);
    EXPECT_EQ(stored(*store, id), commands{});
    ASSERT_TRUE(store->set_restore_commands(id, {"TTL X=0"}));
    EXPECT_EQ(stored(*store, id), commands{"TTL X=0"});

    // Opening the migrated file again changes nothing.
    store.reset();
    store = open_store();
    ASSERT_TRUE(store);
    EXPECT_EQ(integer("PRAGMA user_version"), job_store_schema_version);
    EXPECT_EQ(stored(*store, id), commands{"TTL X=0"});
}

}  // namespace
}  // namespace gw::jobs
