#pragma once
// A recording as an HDF5 file (libhdf5, Debian's libhdf5-dev), the binary format of microscopy
// pipelines: one 1-D dataset per column, the columns of the CSV download (frame_text.hpp), appended a
// page at a time, so a recording of any length is written in constant memory:
//
//   /index      uint64   frames received before this row since the start
//   /time_us    int64    the gateway's receive time, microseconds since the Unix epoch
//   /loss       uint8    0 on a frame; on a marker: 1 garbled, 2 disconnected, 3 overrun (attribute
//                        "names": "none,garbled,disconnected,overrun")
//   /<A>_um     float64  micrometres per axis of the recording (NaN where unknown, and on markers)
//   /<A>_counts int32    the controller's raw counts per axis (0 on markers)
//
// The root's attributes hold the record: id, controller, name, state, reason, started, stopped, axes,
// metadata (JSON text), frames and losses. h5py reads it as
//   pandas.DataFrame({name: f[name][:] for name in f.attrs["columns"].split(",")})
// Not thread-safe: one thread writes a file.

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gateway/recordings/recording.hpp"
#include "gateway/recordings/recording_store.hpp"

namespace gw::recordings {

class hdf5_export {
  public:
    // Creates (or truncates) the file at `path`, with the columns of `r`'s axes.
    static store_result<std::unique_ptr<hdf5_export>> create(const std::string& path,
                                                             const recording_record& r);
    ~hdf5_export();
    hdf5_export(const hdf5_export&) = delete;
    hdf5_export& operator=(const hdf5_export&) = delete;

    store_result<void> append(std::span<const recorded_frame> rows);
    // Writes the record's attributes (`r` as it is now) and closes the file.
    store_result<void> finish(const recording_record& r);

  private:
    struct column;
    hdf5_export(std::int64_t file, std::string path, std::string axes);
    store_result<void> fail(const std::string& what) const;

    std::int64_t file_;  // hid_t
    std::string path_;
    std::string axes_;
    std::vector<column> columns_;
    std::uint64_t rows_ = 0;
};

}  // namespace gw::recordings
