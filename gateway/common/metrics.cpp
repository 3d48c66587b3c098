#include "gateway/common/metrics.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>

namespace gw {

namespace {

// Label values escape backslash, double quote and newline (exposition format 0.0.4).
std::string render_labels(const metric_labels& labels) {
    if (labels.empty()) return {};
    std::string out = "{";
    bool first = true;
    for (const auto& [k, v] : labels) {
        if (!first) out += ',';
        first = false;
        out += k;
        out += "=\"";
        for (char c : v) {
            if (c == '\\')
                out += "\\\\";
            else if (c == '"')
                out += "\\\"";
            else if (c == '\n')
                out += "\\n";
            else
                out += c;
        }
        out += '"';
    }
    out += '}';
    return out;
}

std::string format_value(double v) {
    if (std::isnan(v)) return "NaN";
    if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
    if (v == std::floor(v) && std::fabs(v) < 1e15) return std::to_string(static_cast<std::int64_t>(v));
    char buf[64];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
    return ec == std::errc{} ? std::string(buf, end) : "NaN";
}

// Adds one label to a rendered label set: "{a=\"b\"}" + le -> "{a=\"b\",le=\"0.1\"}".
std::string with_label(const std::string& rendered, const std::string& name, const std::string& value) {
    std::string extra = name + "=\"" + value + "\"";
    if (rendered.empty()) return "{" + extra + "}";
    return rendered.substr(0, rendered.size() - 1) + "," + extra + "}";
}

}  // namespace

std::vector<double> default_latency_buckets() {
    return {0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10};
}

void metrics::describe(std::string name, metric_type type, std::string help, std::vector<double> buckets) {
    std::lock_guard lock(mutex_);
    auto& f = families_[std::move(name)];
    f.type = type;
    f.help = std::move(help);
    f.buckets = std::move(buckets);
}

metrics::series* metrics::find_series(std::string_view name, const metric_labels& labels, metric_type t1,
                                      metric_type t2) {
    auto it = families_.find(name);
    if (it == families_.end() || (it->second.type != t1 && it->second.type != t2)) return nullptr;
    auto& s = it->second.samples[render_labels(labels)];
    if (it->second.type == metric_type::histogram && s.histogram.buckets.empty())
        s.histogram.buckets.assign(it->second.buckets.size(), 0);
    return &s;
}

void metrics::increment(std::string_view name, const metric_labels& labels, double by) {
    std::lock_guard lock(mutex_);
    if (auto* s = find_series(name, labels, metric_type::counter, metric_type::gauge)) s->value += by;
}

void metrics::set(std::string_view name, const metric_labels& labels, double value) {
    std::lock_guard lock(mutex_);
    if (auto* s = find_series(name, labels, metric_type::counter, metric_type::gauge)) s->value = value;
}

void metrics::observe(std::string_view name, const metric_labels& labels, double value) {
    std::lock_guard lock(mutex_);
    auto* s = find_series(name, labels, metric_type::histogram, metric_type::histogram);
    if (s) record(*s, families_.find(name)->second.buckets, value);
}

void metrics::record(series& s, const std::vector<double>& bounds, double value) {
    for (std::size_t i = 0; i < bounds.size(); ++i)
        if (value <= bounds[i]) {
            ++s.histogram.buckets[i];
            break;
        }
    ++s.histogram.count;
    s.histogram.sum += value;
}

metrics::handle metrics::find(std::string_view name, const metric_labels& labels) {
    std::lock_guard lock(mutex_);
    handle h;
    auto it = families_.find(name);
    if (it == families_.end()) return h;
    h.series_ = find_series(name, labels, it->second.type, it->second.type);
    h.type_ = it->second.type;
    h.buckets_ = &it->second.buckets;
    return h;
}

void metrics::increment(const handle& h, double by) {
    if (!h || h.type_ == metric_type::histogram) return;
    std::lock_guard lock(mutex_);
    h.series_->value += by;
}

void metrics::set(const handle& h, double value) {
    if (!h || h.type_ == metric_type::histogram) return;
    std::lock_guard lock(mutex_);
    h.series_->value = value;
}

void metrics::observe(const handle& h, double value) {
    if (!h || h.type_ != metric_type::histogram) return;
    std::lock_guard lock(mutex_);
    record(*h.series_, *h.buckets_, value);
}

double metrics::value(std::string_view name, const metric_labels& labels) const {
    std::lock_guard lock(mutex_);
    auto it = families_.find(name);
    if (it == families_.end()) return 0;
    auto s = it->second.samples.find(render_labels(labels));
    return s == it->second.samples.end() ? 0 : s->second.value;
}

std::uint64_t metrics::count(std::string_view name, const metric_labels& labels) const {
    std::lock_guard lock(mutex_);
    auto it = families_.find(name);
    if (it == families_.end()) return 0;
    auto s = it->second.samples.find(render_labels(labels));
    return s == it->second.samples.end() ? 0 : s->second.histogram.count;
}

std::string metrics::exposition() const {
    std::lock_guard lock(mutex_);
    std::string out;
    for (const auto& [name, f] : families_) {
        out += "# HELP " + name + " " + f.help + "\n";
        out += "# TYPE " + name + " " +
               (f.type == metric_type::counter ? "counter"
                : f.type == metric_type::gauge ? "gauge"
                                               : "histogram") +
               "\n";
        for (const auto& [labels, s] : f.samples) {
            if (f.type != metric_type::histogram) {
                out += name + labels + " " + format_value(s.value) + "\n";
                continue;
            }
            std::uint64_t cumulative = 0;
            for (std::size_t i = 0; i < f.buckets.size(); ++i) {
                cumulative += s.histogram.buckets[i];
                out += name + "_bucket" + with_label(labels, "le", format_value(f.buckets[i])) + " " +
                       std::to_string(cumulative) + "\n";
            }
            out += name + "_bucket" + with_label(labels, "le", "+Inf") + " " +
                   std::to_string(s.histogram.count) + "\n";
            out += name;
            out += "_sum" + labels + " " + format_value(s.histogram.sum) + "\n";
            out += name;
            out += "_count" + labels + " " + std::to_string(s.histogram.count) + "\n";
        }
    }
    return out;
}

}  // namespace gw
