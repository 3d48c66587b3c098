#include "api/common/connection_table.hpp"

#include <gtest/gtest.h>

namespace gw::api {
namespace {

using namespace std::chrono_literals;

struct recording_connection : tracked_connection {
    int sheds = 0;
    int closes = 0;
    void shed() override { ++sheds; }
    void close() override { ++closes; }
};

net::ip::address addr(const char* text) {
    return net::ip::make_address(text);
}

std::shared_ptr<connection_table> table(std::size_t max, std::size_t per_address,
                                        std::chrono::milliseconds patience = 5s,
                                        std::size_t halt_reserve = 8) {
    return std::make_shared<connection_table>(
        connection_table::settings{max, per_address, patience, halt_reserve});
}

// A normal slot: not refused (a refused newcomer may still get a HALT reserve slot).
bool admitted(const connection_table::admission& a) {
    return a.permit && !a.halt_only;
}

TEST(connection_table, counts_permits_until_they_are_destroyed) {
    auto t = table(4, 4);
    auto a = t->admit(addr("127.0.0.1"));
    auto b = t->admit(addr("127.0.0.2"));
    ASSERT_TRUE(a.permit && b.permit);
    EXPECT_EQ(t->open(), 2u);
    a.permit.reset();
    EXPECT_EQ(t->open(), 1u);
}

TEST(connection_table, one_address_is_refused_beyond_its_share) {
    auto t = table(100, 3);
    std::vector<std::shared_ptr<connection_permit>> held;
    for (int i = 0; i < 3; ++i)
        held.push_back(t->admit(addr("10.0.0.1")).permit);
    auto over = t->admit(addr("10.0.0.1"));
    EXPECT_FALSE(admitted(over));
    EXPECT_EQ(over.refused, connection_table::refusal::address_limit);
    EXPECT_NE(over.detail.find("10.0.0.1"), std::string::npos) << over.detail;
    EXPECT_TRUE(admitted(t->admit(addr("10.0.0.2"))));  // another address still gets in
    held.pop_back();
    EXPECT_TRUE(admitted(t->admit(addr("10.0.0.1"))));  // and a freed slot is the address's again
}

TEST(connection_table, an_address_never_gets_every_slot) {
    EXPECT_EQ(table(256, 1000)->per_address_limit(), 224u);
    EXPECT_EQ(table(256, 64)->per_address_limit(), 64u);
    EXPECT_EQ(table(6, 64)->per_address_limit(), 6u);  // small tables: 7/8 rounds to all
    EXPECT_EQ(table(1, 64)->per_address_limit(), 1u);
}

TEST(connection_table, a_newcomer_sheds_the_longest_waiting_header) {
    auto t = table(3, 3);
    const auto t0 = connection_table::clock::now();
    std::vector<std::shared_ptr<recording_connection>> conns;
    std::vector<std::shared_ptr<connection_permit>> permits;
    for (int i = 0; i < 3; ++i) {
        auto a = t->admit(addr(("10.0.0." + std::to_string(i + 1)).c_str()), t0 + std::chrono::seconds(i));
        conns.push_back(std::make_shared<recording_connection>());
        a.permit->track(conns.back());
        permits.push_back(a.permit);
    }
    permits[0]->set_phase(connection_phase::serving);  // being served: never shed
    auto d = t->admit(addr("10.0.0.9"), t0 + 10s);
    ASSERT_TRUE(d.permit);
    auto victim = d.shed.lock();
    ASSERT_EQ(victim, conns[1]);  // the oldest of those still waiting for their header
    victim->shed();
    EXPECT_EQ(t->open(), 3u);  // the victim's slot is the newcomer's at once
    permits[1].reset();        // the victim's session ends later: no double count
    EXPECT_EQ(t->open(), 3u);
}

TEST(connection_table, the_busiest_address_is_shed_first) {
    auto t = table(4, 4);
    const auto t0 = connection_table::clock::now();
    auto lone = std::make_shared<recording_connection>();
    auto first = t->admit(addr("10.0.0.1"), t0);  // the oldest, but alone on its address
    first.permit->track(lone);
    std::vector<std::shared_ptr<connection_permit>> held;
    std::vector<std::shared_ptr<recording_connection>> crowd;
    for (int i = 0; i < 3; ++i) {
        auto a = t->admit(addr("10.0.0.2"), t0 + 1s);
        crowd.push_back(std::make_shared<recording_connection>());
        a.permit->track(crowd.back());
        held.push_back(a.permit);
    }
    auto d = t->admit(addr("10.0.0.3"), t0 + 2s);
    ASSERT_TRUE(d.permit);
    EXPECT_NE(d.shed.lock(), lone);
    EXPECT_NE(d.shed.lock(), nullptr);
}

TEST(connection_table, served_and_freshly_idle_connections_are_not_shed) {
    auto t = table(2, 2, 5s);
    auto a = t->admit(addr("10.0.0.1"));
    auto b = t->admit(addr("10.0.0.2"));
    a.permit->set_phase(connection_phase::serving);
    b.permit->set_phase(connection_phase::idle);
    auto c = t->admit(addr("10.0.0.3"));
    EXPECT_FALSE(admitted(c));
    EXPECT_EQ(c.refused, connection_table::refusal::connection_limit);
    // Idle for longer than the grace: it may go.
    auto later = t->admit(addr("10.0.0.3"), connection_table::clock::now() + 6s);
    EXPECT_TRUE(admitted(later));
}

TEST(connection_table, a_slow_body_is_shed_after_the_waiting_and_only_once_patience_is_over) {
    auto t = table(3, 3, 5s);
    const auto now = connection_table::clock::now();
    auto body = t->admit(addr("10.0.0.1"));
    auto idle = t->admit(addr("10.0.0.2"));
    auto header = t->admit(addr("10.0.0.3"));
    auto c_body = std::make_shared<recording_connection>();
    auto c_idle = std::make_shared<recording_connection>();
    auto c_header = std::make_shared<recording_connection>();
    body.permit->track(c_body);
    idle.permit->track(c_idle);
    header.permit->track(c_header);
    body.permit->set_phase(connection_phase::reading_body);
    idle.permit->set_phase(connection_phase::idle);
    // A fresh body and a fresh idle connection are left alone: only the waiting header goes.
    auto first = t->admit(addr("10.0.0.9"), now + 1s);
    EXPECT_EQ(first.shed.lock(), c_header);
    first.permit->set_phase(connection_phase::serving);
    EXPECT_FALSE(admitted(t->admit(addr("10.0.0.9"), now + 2s)));
    // Past patience: the idle connection before the body.
    auto second = t->admit(addr("10.0.0.8"), now + 6s);
    EXPECT_EQ(second.shed.lock(), c_idle);
    second.permit->set_phase(connection_phase::serving);
    auto third = t->admit(addr("10.0.0.7"), now + 6s);
    EXPECT_EQ(third.shed.lock(), c_body);
}

TEST(connection_table, a_connection_closing_after_its_answer_is_shed_before_one_waiting_for_its_header) {
    auto t = table(2, 2, 5s);
    auto header = t->admit(addr("10.0.0.1"));
    auto closing = t->admit(addr("10.0.0.2"), connection_table::clock::now() + 1s);  // the newer one
    auto c_header = std::make_shared<recording_connection>();
    auto c_closing = std::make_shared<recording_connection>();
    header.permit->track(c_header);
    closing.permit->track(c_closing);
    closing.permit->set_phase(connection_phase::closing);  // refused from its header, lingering
    auto c = t->admit(addr("10.0.0.3"), connection_table::clock::now() + 2s);
    EXPECT_EQ(c.shed.lock(), c_closing);
}

TEST(connection_table, a_newcomer_the_limits_refuse_gets_a_halt_reserve_slot_outside_the_count) {
    auto t = table(2, 2, 5s, 2);
    auto a = t->admit(addr("10.0.0.1"));
    auto b = t->admit(addr("10.0.0.2"));
    a.permit->set_phase(connection_phase::serving);  // WebSockets: never shed
    b.permit->set_phase(connection_phase::serving);
    auto c = t->admit(addr("10.0.0.3"));
    ASSERT_TRUE(c.permit);
    EXPECT_TRUE(c.halt_only);
    EXPECT_TRUE(c.permit->halt_only());
    EXPECT_EQ(c.refused, connection_table::refusal::connection_limit);
    EXPECT_NE(c.detail.find("HALT"), std::string::npos) << c.detail;
    EXPECT_EQ(t->open(), 2u);  // the reserve does not count
    // The reserve is full: the one that waited longest for its header makes room.
    auto c_conn = std::make_shared<recording_connection>();
    c.permit->track(c_conn);
    const auto now = connection_table::clock::now();
    auto d = t->admit(addr("10.0.0.4"), now + 1s);
    auto d_conn = std::make_shared<recording_connection>();
    d.permit->track(d_conn);
    auto e = t->admit(addr("10.0.0.5"), now + 2s);
    EXPECT_TRUE(e.halt_only);
    EXPECT_EQ(e.shed.lock(), c_conn);
    // A reserve slot serving its HALT is never shed: with both serving, a newcomer gets nothing.
    d.permit->set_phase(connection_phase::serving);
    e.permit->set_phase(connection_phase::serving);
    auto f = t->admit(addr("10.0.0.6"), now + 3s);
    EXPECT_FALSE(f.permit);
    // A freed reserve slot is there for the next one.
    e.permit.reset();
    EXPECT_TRUE(t->admit(addr("10.0.0.6"), now + 4s).halt_only);
}

TEST(connection_table, an_address_over_its_share_gets_a_halt_reserve_slot_too) {
    auto t = table(100, 1);
    auto a = t->admit(addr("10.0.0.1"));
    auto over = t->admit(addr("10.0.0.1"));
    ASSERT_TRUE(over.permit);
    EXPECT_TRUE(over.halt_only);
    EXPECT_EQ(over.refused, connection_table::refusal::address_limit);
    EXPECT_EQ(t->open(), 1u);
}

TEST(connection_table, close_all_closes_every_tracked_connection) {
    auto t = table(4, 4);
    auto a = t->admit(addr("10.0.0.1"));
    auto b = t->admit(addr("10.0.0.2"));
    auto ca = std::make_shared<recording_connection>();
    auto cb = std::make_shared<recording_connection>();
    a.permit->track(ca);
    b.permit->track(cb);
    t->close_all();
    EXPECT_EQ(ca->closes, 1);
    EXPECT_EQ(cb->closes, 1);
    EXPECT_EQ(ca->sheds, 0);
}

}  // namespace
}  // namespace gw::api
