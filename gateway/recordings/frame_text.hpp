#pragma once
// A recording's rows as text, for its downloads: CSV (a header line, then one line per row, `index`
// first) and JSON Lines (one object per row, with the CSV's columns as its keys). Both have the same
// columns, so pandas reads either into the same table:
//
//   index,time_us,loss,X_um,Y_um,X_counts,Y_counts
//   0,1765000000000123,,1000.5,-20,20010,-400
//   5,1765000000010456,garbled,,,,          <- a marker: frames were lost before frame 5
//
// `loss` is empty on a frame; on a marker it names why frames were lost, and the marker's positions
// are empty (null in JSON). Axis columns follow the recording's axes, micrometres first (empty where
// the axis's counts per micrometre are unknown), then the controller's raw counts. Pure.

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gateway/recordings/recording.hpp"

namespace gw::recordings {

// The downloads: the two text forms here, and HDF5 (hdf5_export.hpp).
enum class frame_format : std::uint8_t { csv, jsonl, hdf5 };

// The column names, in order.
std::vector<std::string> frame_columns(const recording_record& r);
// The CSV header line (with its newline).
std::string csv_header(const recording_record& r);
// One row as a JSON object with the columns as keys (a JSON Lines line without its newline).
std::string row_json(const recording_record& r, const recorded_frame& f);
// The event of a recording's live topic (recordings/<id>): its id, controller, state, reason and
// counters (as after `rows`), and `rows`, the rows since the event before:
//   {"id":"r-...","controller":"sim2","state":"recording","reason":"","frames":250,"losses":0,
//    "axes":"XYZ","rows":[{"index":125,"time_us":...,"loss":null,"X_um":...},...]}
std::string live_event_json(const recording_record& r, std::span<const recorded_frame> rows);
// Appends one line per row to `out` (csv or jsonl; hdf5 is not text: nothing).
void append_rows(frame_format format, const recording_record& r, std::span<const recorded_frame> rows,
                 std::string& out);

}  // namespace gw::recordings
