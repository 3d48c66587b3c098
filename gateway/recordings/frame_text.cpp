#include "gateway/recordings/frame_text.hpp"

#include <fmt/format.h>
#include <iterator>

#include <nlohmann/json.hpp>

namespace gw::recordings {

namespace {

// The row's value of axis `i`, or nothing (a marker, or an axis the frame lacks).
template <typename T>
const T* value_at(const std::vector<T>& values, std::size_t i) {
    return i < values.size() ? &values[i] : nullptr;
}

void append_csv(const recording_record& r, const recorded_frame& f, std::string& out) {
    auto it = std::back_inserter(out);
    fmt::format_to(it, "{},{},", f.index, f.time_us);
    if (f.loss != loss_kind::none) out += to_string(f.loss);
    for (std::size_t i = 0; i < r.axes.size(); ++i) {
        out += ',';
        if (const auto* um = value_at(f.um, i); um && *um) fmt::format_to(it, "{}", **um);
    }
    for (std::size_t i = 0; i < r.axes.size(); ++i) {
        out += ',';
        if (const auto* counts = value_at(f.counts, i)) fmt::format_to(it, "{}", *counts);
    }
    out += '\n';
}

}  // namespace

std::string row_json(const recording_record& r, const recorded_frame& f) {
    nlohmann::ordered_json j{{"index", f.index}, {"time_us", f.time_us}};
    j["loss"] = f.loss == loss_kind::none ? nlohmann::ordered_json(nullptr)
                                          : nlohmann::ordered_json(std::string(to_string(f.loss)));
    for (std::size_t i = 0; i < r.axes.size(); ++i) {
        const auto* um = value_at(f.um, i);
        j[std::string(1, r.axes[i]) + "_um"] =
            um && *um ? nlohmann::ordered_json(**um) : nlohmann::ordered_json(nullptr);
    }
    for (std::size_t i = 0; i < r.axes.size(); ++i) {
        const auto* counts = value_at(f.counts, i);
        j[std::string(1, r.axes[i]) + "_counts"] =
            counts ? nlohmann::ordered_json(*counts) : nlohmann::ordered_json(nullptr);
    }
    return j.dump();
}

std::string live_event_json(const recording_record& r, std::span<const recorded_frame> rows) {
    nlohmann::ordered_json head{
        {"id", r.id},         {"controller", r.controller}, {"state", to_string(r.state)},
        {"reason", r.reason}, {"frames", r.frames},         {"losses", r.losses},
        {"axes", r.axes}};
    std::string text = head.dump();
    text.pop_back();  // the closing brace: the rows follow
    text += R"(,"rows":[)";
    for (std::size_t i = 0; i < rows.size(); ++i) {
        if (i > 0) text += ',';
        text += row_json(r, rows[i]);
    }
    text += "]}";
    return text;
}

std::vector<std::string> frame_columns(const recording_record& r) {
    std::vector<std::string> columns{"index", "time_us", "loss"};
    for (char axis : r.axes)
        columns.push_back(std::string(1, axis) + "_um");
    for (char axis : r.axes)
        columns.push_back(std::string(1, axis) + "_counts");
    return columns;
}

std::string csv_header(const recording_record& r) {
    std::string line;
    for (const auto& column : frame_columns(r)) {
        if (!line.empty()) line += ',';
        line += column;
    }
    return line + '\n';
}

void append_rows(frame_format format, const recording_record& r, std::span<const recorded_frame> rows,
                 std::string& out) {
    for (const auto& f : rows) {
        if (format == frame_format::csv)
            append_csv(r, f, out);
        else if (format == frame_format::jsonl)
            out += row_json(r, f) + '\n';
    }
}

}  // namespace gw::recordings
