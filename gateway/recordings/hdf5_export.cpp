#include "gateway/recordings/hdf5_export.hpp"

#include <cmath>
#include <hdf5.h>
#include <limits>
#include <mutex>

#include "gateway/common/timestamp.hpp"

namespace gw::recordings {

namespace {

// Rows per HDF5 chunk: the unit in which the library extends and writes a dataset.
constexpr hsize_t chunk_rows = 16384;

// The library prints its error stack to stderr by default; the errors are returned instead.
void silence_library_errors() {
    static std::once_flag once;
    std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

// Closes an HDF5 handle of any kind on every path.
class handle {
  public:
    explicit handle(hid_t id = -1) : id_(id) {}
    ~handle() {
        if (id_ >= 0) H5Idec_ref(id_);
    }
    handle(const handle&) = delete;
    handle& operator=(const handle&) = delete;
    hid_t get() const { return id_; }
    bool ok() const { return id_ >= 0; }

  private:
    hid_t id_;
};

bool write_text_attribute(hid_t target, const char* name, const std::string& value) {
    handle type(H5Tcopy(H5T_C_S1));
    if (!type.ok() || H5Tset_size(type.get(), H5T_VARIABLE) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
        return false;
    handle space(H5Screate(H5S_SCALAR));
    handle attribute(H5Acreate2(target, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
    const char* text = value.c_str();
    return attribute.ok() && H5Awrite(attribute.get(), type.get(), static_cast<const void*>(&text)) >= 0;
}

bool write_count_attribute(hid_t target, const char* name, std::uint64_t value) {
    handle space(H5Screate(H5S_SCALAR));
    handle attribute(H5Acreate2(target, name, H5T_STD_U64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT));
    return attribute.ok() && H5Awrite(attribute.get(), H5T_NATIVE_UINT64, &value) >= 0;
}

std::string timestamp_of(std::int64_t ms) {
    return format_timestamp(std::chrono::system_clock::time_point(std::chrono::milliseconds(ms)));
}

}  // namespace

// One column: its dataset and the memory type its values are written from.
struct hdf5_export::column {
    std::string name;
    hid_t dataset = -1;
    hid_t memory_type = -1;  // a predefined type: never closed
};

store_result<std::unique_ptr<hdf5_export>> hdf5_export::create(const std::string& path,
                                                               const recording_record& r) {
    using result = store_result<std::unique_ptr<hdf5_export>>;
    silence_library_errors();
    const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (file < 0) return result(boost::system::in_place_error, path + ": cannot create the HDF5 file");
    std::unique_ptr<hdf5_export> out(new hdf5_export(file, path, r.axes));

    struct spec {
        std::string name;
        hid_t file_type, memory_type;
    };
    std::vector<spec> specs{{"index", H5T_STD_U64LE, H5T_NATIVE_UINT64},
                            {"time_us", H5T_STD_I64LE, H5T_NATIVE_INT64},
                            {"loss", H5T_STD_U8LE, H5T_NATIVE_UINT8}};
    for (char axis : r.axes)
        specs.push_back({std::string(1, axis) + "_um", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE});
    for (char axis : r.axes)
        specs.push_back({std::string(1, axis) + "_counts", H5T_STD_I32LE, H5T_NATIVE_INT32});

    const hsize_t empty = 0;
    const hsize_t unlimited = H5S_UNLIMITED;
    handle space(H5Screate_simple(1, &empty, &unlimited));
    handle layout(H5Pcreate(H5P_DATASET_CREATE));
    if (!space.ok() || !layout.ok() || H5Pset_chunk(layout.get(), 1, &chunk_rows) < 0)
        return result(boost::system::in_place_error, path + ": cannot lay out the HDF5 datasets");
    for (const auto& s : specs) {
        const hid_t dataset = H5Dcreate2(file, s.name.c_str(), s.file_type, space.get(), H5P_DEFAULT,
                                         layout.get(), H5P_DEFAULT);
        if (dataset < 0)
            return result(boost::system::in_place_error, path + ": cannot create dataset " + s.name);
        out->columns_.push_back({s.name, dataset, s.memory_type});
    }
    if (!write_text_attribute(out->columns_[2].dataset, "names", "none,garbled,disconnected,overrun"))
        return result(boost::system::in_place_error, path + ": cannot write the loss names");
    return out;
}

hdf5_export::hdf5_export(std::int64_t file, std::string path, std::string axes)
    : file_(file), path_(std::move(path)), axes_(std::move(axes)) {}

hdf5_export::~hdf5_export() {
    for (auto& c : columns_)
        if (c.dataset >= 0) H5Dclose(c.dataset);
    if (file_ >= 0) H5Fclose(file_);
}

store_result<void> hdf5_export::fail(const std::string& what) const {
    return store_result<void>(boost::system::in_place_error, path_ + ": " + what);
}

store_result<void> hdf5_export::append(std::span<const recorded_frame> rows) {
    if (rows.empty()) return {};
    const auto n = static_cast<hsize_t>(rows.size());
    const std::size_t axes = axes_.size();
    // The page's values column by column, as the datasets hold them.
    std::vector<std::uint64_t> index(rows.size());
    std::vector<std::int64_t> time(rows.size());
    std::vector<std::uint8_t> loss(rows.size());
    std::vector<std::vector<double>> um(axes, std::vector<double>(rows.size()));
    std::vector<std::vector<std::int32_t>> counts(axes, std::vector<std::int32_t>(rows.size()));
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const auto& f = rows[i];
        index[i] = f.index;
        time[i] = f.time_us;
        loss[i] = static_cast<std::uint8_t>(f.loss);
        for (std::size_t a = 0; a < axes; ++a) {
            um[a][i] = a < f.um.size() && f.um[a] ? *f.um[a] : std::numeric_limits<double>::quiet_NaN();
            counts[a][i] = a < f.counts.size() ? f.counts[a] : 0;
        }
    }
    std::vector<const void*> data{index.data(), time.data(), loss.data()};
    for (const auto& v : um)
        data.push_back(v.data());
    for (const auto& v : counts)
        data.push_back(v.data());

    const hsize_t start = rows_;
    const hsize_t size = rows_ + n;
    handle memory(H5Screate_simple(1, &n, nullptr));
    for (std::size_t c = 0; c < columns_.size(); ++c) {
        const auto& col = columns_[c];
        if (H5Dset_extent(col.dataset, &size) < 0) return fail("cannot extend dataset " + col.name);
        handle file_space(H5Dget_space(col.dataset));
        if (!file_space.ok() ||
            H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &start, nullptr, &n, nullptr) < 0 ||
            H5Dwrite(col.dataset, col.memory_type, memory.get(), file_space.get(), H5P_DEFAULT, data[c]) < 0)
            return fail("cannot write dataset " + col.name);
    }
    rows_ = size;
    return {};
}

store_result<void> hdf5_export::finish(const recording_record& r) {
    handle root(H5Gopen2(file_, "/", H5P_DEFAULT));
    std::string columns;
    for (const auto& c : columns_)
        columns += (columns.empty() ? "" : ",") + c.name;
    const bool ok =
        root.ok() && write_text_attribute(root.get(), "id", r.id) &&
        write_text_attribute(root.get(), "controller", r.controller) &&
        write_text_attribute(root.get(), "name", r.name) &&
        write_text_attribute(root.get(), "state", std::string(to_string(r.state))) &&
        write_text_attribute(root.get(), "reason", r.reason) &&
        write_text_attribute(root.get(), "started", timestamp_of(r.started_ms)) &&
        write_text_attribute(root.get(), "stopped", r.stopped_ms ? timestamp_of(*r.stopped_ms) : "") &&
        write_text_attribute(root.get(), "axes", r.axes) &&
        write_text_attribute(root.get(), "columns", columns) &&
        write_text_attribute(root.get(), "metadata", r.metadata.dump()) &&
        write_count_attribute(root.get(), "frames", r.frames) &&
        write_count_attribute(root.get(), "losses", r.losses);
    if (!ok) return fail("cannot write the recording's attributes");
    for (auto& c : columns_) {
        H5Dclose(c.dataset);
        c.dataset = -1;
    }
    const herr_t closed = H5Fclose(file_);
    file_ = -1;
    if (closed < 0) return fail("cannot close the HDF5 file");
    return {};
}

}  // namespace gw::recordings
