#pragma once
// A small metrics registry: counters, gauges and histograms with labels, and the Prometheus text
// exposition format (version 0.0.4). Gateway-level so that every layer (api, mqtt, jobs) can count.
//
//   m.describe("gw_http_requests_total", metric_type::counter, "HTTP requests by route and status");
//   m.increment("gw_http_requests_total", {{"route", "/api/v1/health"}, {"status", "200"}});
//   m.observe("gw_controller_command_duration_seconds", {{"controller", "sim1"}}, 0.0021);
//   std::string text = m.exposition();
//
// Thread safety: every method may be called from any thread (one mutex, held for a map update).
// Metrics that were never described are ignored, so a typo cannot create a stray family.

#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace gw {

enum class metric_type { counter, gauge, histogram };

using metric_labels = std::vector<std::pair<std::string, std::string>>;

// Seconds, for command and request latencies: 100 µs .. 10 s.
std::vector<double> default_latency_buckets();

class metrics {
    struct series;

  public:
    // One series, found once and then updated without rendering its labels again (a hot path's, such
    // as HTTP requests). Series are never removed: a handle stays valid as long as the registry.
    class handle {
      public:
        explicit operator bool() const { return series_ != nullptr; }

      private:
        friend class metrics;
        series* series_ = nullptr;
        metric_type type_ = metric_type::counter;
        const std::vector<double>* buckets_ = nullptr;  // a histogram's
    };

    // Declares a family. `buckets` (histograms only) must be ascending; +Inf is implicit.
    void describe(std::string name, metric_type type, std::string help, std::vector<double> buckets = {});

    void increment(std::string_view name, const metric_labels& labels, double by = 1);  // counter, gauge
    void set(std::string_view name, const metric_labels& labels, double value);         // gauge, or a counter
                                                                                 // mirrored from elsewhere
    void observe(std::string_view name, const metric_labels& labels, double value);  // histogram

    // An empty handle for a family that was never described (updating it does nothing).
    handle find(std::string_view name, const metric_labels& labels);
    void increment(const handle& h, double by = 1);  // counter, gauge
    void set(const handle& h, double value);         // gauge, or a counter mirrored from elsewhere
    void observe(const handle& h, double value);     // histogram

    // One sample's current value (counter/gauge), 0 when absent. For tests.
    double value(std::string_view name, const metric_labels& labels) const;
    // Histogram sample count, 0 when absent.
    std::uint64_t count(std::string_view name, const metric_labels& labels) const;

    std::string exposition() const;

  private:
    struct histogram_data {
        std::vector<std::uint64_t> buckets;  // cumulative at exposition time, per bucket here
        std::uint64_t count = 0;
        double sum = 0;
    };
    struct series {
        double value = 0;
        histogram_data histogram;
    };
    struct family {
        metric_type type = metric_type::counter;
        std::string help;
        std::vector<double> buckets;
        std::map<std::string, series> samples;  // key: rendered label set ("{a=\"b\"}")
    };

    static void record(series& s, const std::vector<double>& bounds, double value);  // a histogram's
    series* find_series(std::string_view name, const metric_labels& labels, metric_type t1, metric_type t2);

    mutable std::mutex mutex_;
    std::map<std::string, family, std::less<>> families_;
};

}  // namespace gw
