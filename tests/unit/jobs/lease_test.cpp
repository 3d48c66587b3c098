#include <memory>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "gateway/leases/lease_manager.hpp"

namespace gw {
namespace {

using namespace std::chrono_literals;
using tp = std::chrono::system_clock::time_point;

// A clock the test moves by hand.
struct manual_clock {
    std::shared_ptr<tp> now =
        std::make_shared<tp>(std::chrono::sys_days{std::chrono::year{2026} / 11 / 22} + 5h);
    lease_clock fn() const {
        return [n = now] { return *n; };
    }
    void advance(std::chrono::seconds s) const { *now += s; }
};

TEST(lease, acquire_gives_an_unguessable_id_and_the_times) {
    manual_clock clock;
    lease_manager m(clock.fn());
    auto l = m.acquire("sim1", "alice/notebook", 60s);
    ASSERT_TRUE(l) << l.error().message;
    EXPECT_EQ(l->controller, "sim1");
    EXPECT_EQ(l->holder, "alice/notebook");
    EXPECT_EQ(l->id.size(), 34u);
    EXPECT_EQ(l->id.substr(0, 2), "l-");
    EXPECT_EQ(l->acquired, *clock.now);
    EXPECT_EQ(l->expires, *clock.now + 60s);
    auto c = m.current("sim1");
    ASSERT_TRUE(c);
    EXPECT_EQ(c->id, l->id);
    EXPECT_FALSE(m.current("sim2"));
    auto other = m.acquire("sim2", "bob", 60s);
    ASSERT_TRUE(other);
    EXPECT_NE(other->id, l->id);
}

TEST(lease, all_lists_the_unexpired_leases_by_controller) {
    manual_clock clock;
    lease_manager m(clock.fn());
    EXPECT_TRUE(m.all().empty());
    ASSERT_TRUE(m.acquire("sim2", "bob", 60s));
    ASSERT_TRUE(m.acquire("sim1", "alice", 10s));
    auto all = m.all();
    ASSERT_EQ(all.size(), 2u);
    EXPECT_EQ(all[0].controller, "sim1");
    EXPECT_EQ(all[1].controller, "sim2");
    clock.advance(10s);  // alice's lease ends now
    all = m.all();
    ASSERT_EQ(all.size(), 1u);
    EXPECT_EQ(all[0].holder, "bob");
    EXPECT_FALSE(m.current("sim1"));
}

TEST(lease, a_second_acquire_conflicts_naming_holder_and_expiry) {
    manual_clock clock;
    lease_manager m(clock.fn());
    ASSERT_TRUE(m.acquire("sim1", "alice", 60s));
    auto r = m.acquire("sim1", "bob", 60s);
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().kind, operation_error_kind::leased);
    EXPECT_NE(r.error().message.find("alice"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("2026-11-22T05:01:00.000Z"), std::string::npos) << r.error().message;
}

TEST(lease, expiry_frees_the_controller) {
    manual_clock clock;
    lease_manager m(clock.fn());
    auto l = m.acquire("sim1", "alice", 10s);
    ASSERT_TRUE(l);
    clock.advance(9s);
    EXPECT_TRUE(m.current("sim1"));
    EXPECT_FALSE(m.check("sim1", std::nullopt));
    clock.advance(1s);  // at the expiry instant it is over
    EXPECT_FALSE(m.current("sim1"));
    EXPECT_TRUE(m.check("sim1", std::nullopt));
    auto b = m.acquire("sim1", "bob", 10s);
    ASSERT_TRUE(b);
    EXPECT_EQ(b->holder, "bob");
    // The expired lease cannot be renewed or released any more.
    auto renew = m.renew("sim1", l->id, 10s);
    ASSERT_FALSE(renew);
    EXPECT_EQ(renew.error().kind, operation_error_kind::invalid_state);
}

TEST(lease, renew_extends_from_now) {
    manual_clock clock;
    lease_manager m(clock.fn());
    auto l = m.acquire("sim1", "alice", 10s);
    ASSERT_TRUE(l);
    clock.advance(8s);
    auto r = m.renew("sim1", l->id, 30s);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(r->id, l->id);
    EXPECT_EQ(r->acquired, l->acquired);
    EXPECT_EQ(r->expires, *clock.now + 30s);
    clock.advance(25s);  // past the original expiry
    auto c = m.current("sim1");
    ASSERT_TRUE(c);
    EXPECT_EQ(c->id, l->id);
}

TEST(lease, wrong_id_is_refused_for_renew_release_and_check) {
    manual_clock clock;
    lease_manager m(clock.fn());
    auto l = m.acquire("sim1", "alice", 60s);
    ASSERT_TRUE(l);
    auto renew = m.renew("sim1", "l-00000000000000000000000000000000", 60s);
    ASSERT_FALSE(renew);
    EXPECT_EQ(renew.error().kind, operation_error_kind::invalid_state);
    auto release = m.release("sim1", "l-wrong", false);
    ASSERT_FALSE(release);
    EXPECT_EQ(release.error().kind, operation_error_kind::invalid_state);
    EXPECT_TRUE(m.current("sim1"));
    // The right id on the wrong controller is still wrong.
    ASSERT_TRUE(m.acquire("sim2", "bob", 60s));
    EXPECT_FALSE(m.renew("sim2", l->id, 60s));
    EXPECT_FALSE(m.release("sim2", l->id, false));
    auto check = m.check("sim2", std::string_view(l->id));
    ASSERT_FALSE(check);
    EXPECT_EQ(check.error().kind, operation_error_kind::leased);
    EXPECT_NE(check.error().message.find("bob"), std::string::npos);
}

TEST(lease, release_with_the_id_or_force) {
    manual_clock clock;
    lease_manager m(clock.fn());
    auto l = m.acquire("sim1", "alice", 60s);
    ASSERT_TRUE(l);
    auto r = m.release("sim1", l->id, false);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->id, l->id);
    EXPECT_FALSE(m.current("sim1"));
    auto none = m.release("sim1", l->id, false);
    ASSERT_FALSE(none);
    EXPECT_EQ(none.error().kind, operation_error_kind::invalid_state);

    ASSERT_TRUE(m.acquire("sim1", "bob", 60s));
    auto forced = m.release("sim1", "", true);
    ASSERT_TRUE(forced) << forced.error().message;
    EXPECT_EQ(forced->holder, "bob");
    EXPECT_FALSE(m.current("sim1"));
    auto nothing = m.release("sim1", "", true);
    ASSERT_FALSE(nothing);
    EXPECT_EQ(nothing.error().kind, operation_error_kind::invalid_state);
}

TEST(lease, ttl_bounds) {
    manual_clock clock;
    lease_manager m(clock.fn());
    struct row {
        std::chrono::seconds ttl;
        bool ok;
    };
    for (auto [ttl, ok] :
         {row{0s, false}, row{-5s, false}, row{1s, true}, row{24h, true}, row{24h + 1s, false}}) {
        auto r = m.acquire("sim-" + std::to_string(ttl.count()), "alice", ttl);
        EXPECT_EQ(r.has_value(), ok) << ttl.count();
        if (!r) {
            EXPECT_EQ(r.error().kind, operation_error_kind::invalid_value);
            EXPECT_EQ(r.error().field, "ttl_s");
        }
    }
    auto l = m.acquire("sim1", "alice", 60s);
    ASSERT_TRUE(l);
    auto bad = m.renew("sim1", l->id, 0s);
    ASSERT_FALSE(bad);
    EXPECT_EQ(bad.error().kind, operation_error_kind::invalid_value);
    EXPECT_EQ(m.current("sim1")->expires, l->expires);  // unchanged
}

TEST(lease, check_with_and_without_the_id) {
    manual_clock clock;
    lease_manager m(clock.fn());
    EXPECT_TRUE(m.check("sim1", std::nullopt));
    EXPECT_TRUE(m.check("sim1", std::string_view("l-anything")));  // not leased: any id passes
    auto l = m.acquire("sim1", "alice/nb", 120s);
    ASSERT_TRUE(l);
    EXPECT_TRUE(m.check("sim1", std::string_view(l->id)));
    for (std::optional<std::string_view> id :
         {std::optional<std::string_view>{}, std::optional<std::string_view>{"l-wrong"}}) {
        auto r = m.check("sim1", id);
        ASSERT_FALSE(r);
        EXPECT_EQ(r.error().kind, operation_error_kind::leased);
        EXPECT_NE(r.error().message.find("alice/nb"), std::string::npos) << r.error().message;
        EXPECT_NE(r.error().message.find("2026-11-22T05:02:00.000Z"), std::string::npos) << r.error().message;
    }
    EXPECT_TRUE(m.check("sim2", std::nullopt));  // other controllers are free
}

TEST(lease, the_default_clock_is_the_system_clock) {
    lease_manager m;
    auto before = std::chrono::system_clock::now();
    auto l = m.acquire("sim1", "alice", 60s);
    ASSERT_TRUE(l);
    EXPECT_GE(l->acquired, before);
    EXPECT_LE(l->acquired, std::chrono::system_clock::now());
}

TEST(lease, concurrent_acquires_give_one_holder) {
    manual_clock clock;
    lease_manager m(clock.fn());
    std::vector<std::thread> threads;
    std::vector<int> won(8, 0);
    for (int i = 0; i < 8; ++i)
        threads.emplace_back(
            [&, i] { won[static_cast<std::size_t>(i)] = m.acquire("sim1", "t", 60s) ? 1 : 0; });
    for (auto& t : threads)
        t.join();
    int total = 0;
    for (int w : won)
        total += w;
    EXPECT_EQ(total, 1);
}

}  // namespace
}  // namespace gw
