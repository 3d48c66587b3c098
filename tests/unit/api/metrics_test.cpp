#include "gateway/common/metrics.hpp"

#include <gtest/gtest.h>

namespace gw {
namespace {

TEST(metrics, counters_gauges_and_histograms_in_prometheus_text) {
    metrics m;
    m.describe("t_requests_total", metric_type::counter, "Requests");
    m.describe("t_clients", metric_type::gauge, "Clients");
    m.describe("t_latency_seconds", metric_type::histogram, "Latency", {0.1, 1});
    m.increment("t_requests_total", {{"route", "/a"}, {"status", "200"}});
    m.increment("t_requests_total", {{"route", "/a"}, {"status", "200"}}, 2);
    m.set("t_clients", {}, 3);
    m.increment("t_clients", {}, -1);
    m.observe("t_latency_seconds", {{"c", "x"}}, 0.05);
    m.observe("t_latency_seconds", {{"c", "x"}}, 0.5);
    m.observe("t_latency_seconds", {{"c", "x"}}, 5);
    m.increment("t_undeclared_total", {});  // ignored

    EXPECT_EQ(m.value("t_requests_total", {{"route", "/a"}, {"status", "200"}}), 3);
    EXPECT_EQ(m.value("t_clients", {}), 2);
    EXPECT_EQ(m.count("t_latency_seconds", {{"c", "x"}}), 3u);

    auto text = m.exposition();
    EXPECT_NE(text.find("# HELP t_requests_total Requests\n# TYPE t_requests_total counter\n"),
              std::string::npos);
    EXPECT_NE(text.find("t_requests_total{route=\"/a\",status=\"200\"} 3\n"), std::string::npos);
    EXPECT_NE(text.find("# TYPE t_clients gauge\nt_clients 2\n"), std::string::npos);
    EXPECT_NE(text.find("t_latency_seconds_bucket{c=\"x\",le=\"0.1\"} 1\n"), std::string::npos);
    EXPECT_NE(text.find("t_latency_seconds_bucket{c=\"x\",le=\"1\"} 2\n"), std::string::npos);
    EXPECT_NE(text.find("t_latency_seconds_bucket{c=\"x\",le=\"+Inf\"} 3\n"), std::string::npos);
    EXPECT_NE(text.find("t_latency_seconds_sum{c=\"x\"} 5.55\n"), std::string::npos);
    EXPECT_NE(text.find("t_latency_seconds_count{c=\"x\"} 3\n"), std::string::npos);
    EXPECT_EQ(text.find("t_undeclared_total"), std::string::npos);
}

TEST(metrics, label_values_are_escaped) {
    metrics m;
    m.describe("t_total", metric_type::counter, "T");
    m.increment("t_total", {{"v", "a\"b\\c\nd"}});
    EXPECT_NE(m.exposition().find("t_total{v=\"a\\\"b\\\\c\\nd\"} 1\n"), std::string::npos);
}

TEST(metrics, a_counter_cannot_be_observed_and_a_histogram_cannot_be_incremented) {
    metrics m;
    m.describe("t_total", metric_type::counter, "T");
    m.describe("t_seconds", metric_type::histogram, "S", {1});
    m.observe("t_total", {}, 1);
    m.increment("t_seconds", {});
    EXPECT_EQ(m.value("t_total", {}), 0);
    EXPECT_EQ(m.count("t_seconds", {}), 0u);
}

TEST(metrics, a_handle_updates_the_series_it_was_found_for) {
    metrics m;
    m.describe("t_total", metric_type::counter, "T");
    m.describe("t_seconds", metric_type::histogram, "S", {0.1, 1});
    const auto requests = m.find("t_total", {{"route", "/a"}});
    const auto latency = m.find("t_seconds", {{"route", "/a"}});
    m.increment(requests);
    m.increment(requests, 2);
    m.increment("t_total", {{"route", "/a"}});  // the same series by its labels
    m.observe(latency, 0.05);
    m.observe(latency, 0.5);
    m.describe("t_mirrored_total", metric_type::counter, "M");
    const auto mirrored = m.find("t_mirrored_total", {});
    m.set(mirrored, 7);
    m.set(mirrored, 9);
    EXPECT_EQ(m.value("t_mirrored_total", {}), 9);
    EXPECT_EQ(m.value("t_total", {{"route", "/a"}}), 4);
    EXPECT_EQ(m.value("t_total", {{"route", "/b"}}), 0);
    EXPECT_EQ(m.count("t_seconds", {{"route", "/a"}}), 2u);
    EXPECT_NE(m.exposition().find("t_seconds_bucket{route=\"/a\",le=\"0.1\"} 1\n"), std::string::npos);

    // A handle of the wrong kind, or of a family never described, changes nothing.
    m.observe(requests, 1);
    m.increment(latency);
    m.set(latency, 3);
    const auto unknown = m.find("t_undeclared_total", {});
    EXPECT_FALSE(unknown);
    m.increment(unknown);
    EXPECT_EQ(m.value("t_total", {{"route", "/a"}}), 4);
    EXPECT_EQ(m.count("t_seconds", {{"route", "/a"}}), 2u);
    EXPECT_EQ(m.exposition().find("t_undeclared_total"), std::string::npos);
}

}  // namespace
}  // namespace gw
