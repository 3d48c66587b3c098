// storage.retention for the audit trail: audit_store::delete_old by age and count, in batches, and the
// audit_log's sweep on its writer thread (at start, then every sweep_interval), on real SQLite files.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/audit/audit_log.hpp"
#include "gateway/audit/audit_store.hpp"

namespace gw::audit {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class audit_retention_test : public ::testing::Test {
  protected:
    void SetUp() override {
        std::string tmpl = (fs::temp_directory_path() / "gw-audit-retention-XXXXXX").string();
        ASSERT_NE(mkdtemp(tmpl.data()), nullptr);
        dir_ = tmpl;
    }
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    fs::path dir_;
};

audit_entry entry_at(std::int64_t time_ms, std::string action) {
    audit_entry e;
    e.time_ms = time_ms;
    e.principal = "alice";
    e.role = "operator";
    e.transport = "rest";
    e.action = std::move(action);
    e.controller = "sim1";
    e.outcome = "ok";
    e.detail = nlohmann::json::object();
    return e;
}

std::vector<std::string> actions(const audit_store& store) {
    audit_filter f;
    f.limit = 500;
    const auto page = store.query(f);  // kept: a range-for over a temporary's member would outlive it
    std::vector<std::string> out;
    for (const auto& e : page->entries)
        out.push_back(e.action);
    return out;  // newest first
}

TEST_F(audit_retention_test, delete_old_goes_by_age_and_by_count_in_batches) {
    auto store = std::move(*audit_store::open(dir_.string()));
    std::vector<audit_entry> entries;
    for (int i = 0; i < 6; ++i)
        entries.push_back(entry_at(1000 * (i + 1), "a" + std::to_string(i)));
    ASSERT_TRUE(store->append(entries));
    EXPECT_EQ(*store->delete_old(std::nullopt, std::nullopt, 10), 0U);
    // Recorded before 3000 ms: a0 and a1, one per batch.
    EXPECT_EQ(*store->delete_old(3000, std::nullopt, 1), 1U);
    EXPECT_EQ(*store->delete_old(3000, std::nullopt, 1), 1U);
    EXPECT_EQ(*store->delete_old(3000, std::nullopt, 1), 0U);
    EXPECT_EQ(actions(*store), (std::vector<std::string>{"a5", "a4", "a3", "a2"}));
    // The newest three stay.
    EXPECT_EQ(*store->delete_old(std::nullopt, 3, 10), 1U);
    EXPECT_EQ(actions(*store), (std::vector<std::string>{"a5", "a4", "a3"}));
}

TEST_F(audit_retention_test, the_log_sweeps_at_start_and_again_after_its_interval) {
    {
        auto store = std::move(*audit_store::open(dir_.string()));
        std::vector<audit_entry> entries;
        for (int i = 0; i < 450; ++i)
            entries.push_back(entry_at(1000 + i, "old" + std::to_string(i)));
        ASSERT_TRUE(store->append(entries));
    }
    history_retention retention;
    retention.max_audit_entries = 10;
    retention.sweep_interval = 1s;
    auto log = std::move(*audit_log::open(dir_.string(), nullptr, retention));
    const auto count = [&] {
        std::promise<std::size_t> got;
        audit_filter f;
        f.limit = 500;
        log->async_query(f, [&](auto page) { got.set_value(page ? page->entries.size() : 9999); });
        return got.get_future().get();
    };
    // At start: 450 -> 10, in three batches of at most 200.
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    while (count() != 10 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(20ms);
    EXPECT_EQ(count(), 10U);
    // New entries beyond the bound are kept until the next sweep, then cut back to the newest 10.
    for (int i = 0; i < 5; ++i)
        log->record(entry_at(100'000 + i, "new" + std::to_string(i)));
    EXPECT_GE(count(), 10U);
    while (count() != 10 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(50ms);
    EXPECT_EQ(count(), 10U);
    std::promise<std::vector<std::string>> newest;
    audit_filter f;
    f.limit = 1;
    log->async_query(f, [&](auto page) { newest.set_value({page->entries.at(0).action}); });
    EXPECT_EQ(newest.get_future().get(), std::vector<std::string>{"new4"});
}

}  // namespace
}  // namespace gw::audit
