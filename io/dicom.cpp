/* dicom.cpp - the DICOM series reader of picvr_io.h (picvr_io_load_dicom,
 * picvr_io_is_dicom), through GDCM; its parts share io/dicom.h.
 *
 * Two passes.  First every regular file of the folder is read and its header parsed
 * (gdcm::Reader::ReadUpToTag, Pixel Data skipped: io/dicom_slice.cpp); files that are not
 * DICOM or carry no image (no Rows/Columns) are skipped, the rest grouped by
 * SeriesInstanceUID.  The chosen series is checked (one layout and one orientation for
 * all slices), sorted along the slice normal, and its geometry computed from the
 * positions (io/dicom_series.cpp).  Only after the volume's byte size is validated is it
 * allocated (here); the second pass reads each slice whole and decodes its pixels with
 * GDCM's codecs (native, JPEG, JPEG-LS, JPEG 2000, RLE), from an image described by the
 * attributes checked here (io/dicom_pixels.cpp).
 *
 * GDCM 3.0.21 as Debian builds it is not safe on hostile input by itself: it allocates
 * what lengths announce, its assertions are compiled in (an abort), several codecs
 * trust the DICOM header over their stream or the reverse, and its JPEG fallback runs
 * an external program.  So every file is first walked (io/dicom_walk.cpp: structure,
 * lengths, nesting) and every compressed stream's own header checked against the DICOM
 * header before GDCM sees them; the places where GDCM is avoided or fenced say why.
 * Attribute values are parsed from their bytes, not through gdcm::Attribute, so that a
 * malformed value is a refusal with a message.  Every GDCM call runs inside the
 * try/catch of picvr_io_load_dicom: no exception leaves the reader.
 */
#include "picvr_io.h"
#include "io/internal.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#ifndef PICVR_IO_NO_DICOM

#include "io/dicom.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include <gdcmTrace.h>

/* The largest volume this reader allocates.  A header may claim any size, and a slice of
   a few kB, compressed, can claim gigabytes legitimately; the fuzz build lowers it (make
   fuzz) so that such claims are refused instead of allocated. */
#ifndef PICVR_IO_DICOM_MAX_BYTES
#define PICVR_IO_DICOM_MAX_BYTES ((uint64_t)16 << 30)
#endif

namespace {

using namespace picvr_io_dicom;

/* How the stored values become the volume's voxels. */
struct Values {
    picvr_voxel_type type;
    bool to_f32;            /* converted to float32 ... */
    bool rescale_varies;    /* ... each slice with its own rescale applied */
};

/* The voxel type of the series (sorted: its first slice by position stands for all),
   the conversions said in the warnings. */
Values choose_values(Series &series) {
    const Slice &ref = series.slices[0];
    std::vector<std::string> &warnings = series.warnings;
    bool rescale_varies = false;
    for (const Slice &s : series.slices)
        if (s.slope != ref.slope || s.intercept != ref.intercept) rescale_varies = true;
    const bool u32 = ref.bits == 32 && ref.pixrep == 0;
    const bool to_f32 = rescale_varies || u32;
    picvr_voxel_type type;
    if (to_f32) type = PICVR_VOXEL_FLOAT32;
    else if (ref.bits == 8) type = ref.pixrep ? PICVR_VOXEL_INT8 : PICVR_VOXEL_UINT8;
    else if (ref.bits == 16) type = ref.pixrep ? PICVR_VOXEL_INT16 : PICVR_VOXEL_UINT16;
    else type = PICVR_VOXEL_INT32;
    if (rescale_varies) warnings.push_back("rescale differs between slices: converted to float32 with each slice's rescale applied");
    else if (u32) warnings.push_back("uint32 pixels converted to float32 (exact below 2^24)");
    if (ref.photometric == "MONOCHROME1")
        warnings.push_back("MONOCHROME1: values kept as stored (inverted display: higher is darker)");
    return Values{type, to_f32, rescale_varies};
}

/* The volume's byte size: a valid layout, and within PICVR_IO_DICOM_MAX_BYTES. */
picvr_io_status volume_bytes(const char *path, const Series &series, picvr_voxel_type type, size_t &bytes, char *err,
                             size_t err_size) {
    const Slice &ref = series.slices[0];
    const size_t nz = series.slices.size();
    picvr_io_layout layout = {{ref.cols, ref.rows, (uint32_t)nz}, type};
    char lerr[160];
    picvr_io_status status = picvr_io_layout_bytes(&layout, &bytes, lerr, sizeof lerr);
    if (status != PICVR_IO_OK) FAIL(status, "%s: %s", path, lerr);
    if ((uint64_t)bytes > (uint64_t)(PICVR_IO_DICOM_MAX_BYTES))
        FAIL(PICVR_IO_ERROR_SIZE_OVERFLOW, "%s: %ux%ux%zu voxels need %zu bytes, more than this reader's limit of %llu", path,
             ref.cols, ref.rows, nz, bytes, (unsigned long long)(PICVR_IO_DICOM_MAX_BYTES));
    return PICVR_IO_OK;
}

/* The warnings joined for volume->warning. */
std::string joined(const std::vector<std::string> &warnings) {
    std::string w;
    for (const std::string &s : warnings) w += (w.empty() ? "" : "; ") + s;
    return w;
}

/* Pass 2: every slice decoded, in order, into a malloc'd buffer of `bytes` (*out, the
   caller's); freed on every failure, thrown ones included. */
picvr_io_status read_slices(const char *path, const Series &series, const Values &values, size_t bytes,
                            unsigned char *&out, char *err, size_t err_size) {
    const std::vector<Slice> &slices = series.slices;
    const Slice &ref = slices[0];
    const size_t nz = slices.size();
    const bool to_f32 = values.to_f32, rescale_varies = values.rescale_varies;
    picvr_io_status status = PICVR_IO_OK;
    const size_t stored_bytes_per_slice = (size_t)ref.cols * ref.rows * (ref.bits / 8);   /* fits: <= bytes */
    const size_t out_bytes_per_slice = bytes / nz;
    unsigned char *data = static_cast<unsigned char *>(malloc(bytes));
    if (!data) FAIL(PICVR_IO_ERROR_OUT_OF_MEMORY, "%s: out of memory for %zu bytes", path, bytes);
    try {
        std::vector<unsigned char> tmp(to_f32 ? stored_bytes_per_slice : 0);
        for (size_t k = 0; k < nz; k++) {
            const Slice &s = slices[k];
            unsigned char *dst = data + k * out_bytes_per_slice;
            status = decode_slice(s, to_f32 ? tmp.data() : dst, stored_bytes_per_slice, err, err_size);
            if (status != PICVR_IO_OK) break;
            if (to_f32)
                to_float(tmp.data(), reinterpret_cast<float *>(dst), (size_t)ref.cols * ref.rows, ref.bits, ref.pixrep,
                         rescale_varies ? s.slope : 1.0, rescale_varies ? s.intercept : 0.0);
        }
    } catch (...) {
        free(data);
        throw;
    }
    if (status != PICVR_IO_OK) {
        free(data);
        return status;
    }
    out = data;
    return PICVR_IO_OK;
}

/* Fills *volume with the decoded series (data, `bytes`; *volume takes it), its placement
   and its values; a spacing or position beyond float is refused (data freed). */
picvr_io_status fill_volume(const char *path, const Series &series, const Placement &placement, const Values &values,
                            const std::string &warning, unsigned char *data, size_t bytes, picvr_io_volume *volume,
                            char *err, size_t err_size) {
    const std::vector<Slice> &slices = series.slices;
    const Slice &ref = slices[0];
    const bool rescale_varies = values.rescale_varies;
    volume->dims[0] = ref.cols;
    volume->dims[1] = ref.rows;
    volume->dims[2] = (uint32_t)slices.size();
    volume->type = values.type;
    volume->data = data;
    volume->size = bytes;
    volume->spacing[0] = (float)ref.ps[1];   /* along a row: the column spacing */
    volume->spacing[1] = (float)ref.ps[0];
    volume->spacing[2] = (float)placement.slice_spacing;
    for (int c = 0; c < 3; c++) {
        volume->origin[c] = (float)slices[0].ipp[c];
        volume->direction[0 + c] = (float)placement.row[c];
        volume->direction[3 + c] = (float)placement.col[c];
        volume->direction[6 + c] = (float)placement.axis_z[c];
    }
    volume->value_scale = rescale_varies ? 1.0 : ref.slope;
    volume->value_offset = rescale_varies ? 0.0 : ref.intercept;
    snprintf(volume->modality, sizeof volume->modality, "%s", ref.modality.c_str());
    volume->patient_frame = 1;   /* DICOM's patient coordinates are LPS */
    volume->has_origin = 1;
    snprintf(volume->warning, sizeof volume->warning, "%s", warning.c_str());
    for (int i = 0; i < 3; i++)
        if (!(volume->spacing[i] > 0.0f) || !std::isfinite(volume->spacing[i]) || !std::isfinite(volume->origin[i])) {
            picvr_io_free(volume);
            FAIL(PICVR_IO_ERROR_BAD_DIMS, "%s: a spacing or position beyond float", path);
        }
    return PICVR_IO_OK;
}

/* The load, from stat() to a filled *volume; throws what GDCM or the standard library
   throw (picvr_io_load_dicom catches it). */
picvr_io_status load(const char *path, picvr_io_volume *volume, char *err, size_t err_size) {
    struct stat st;
    if (stat(path, &st) != 0) FAIL(PICVR_IO_ERROR_OPEN, "%s: %s", path, strerror(errno));
    const bool folder = S_ISDIR(st.st_mode);
    if (!folder && !S_ISREG(st.st_mode)) FAIL(PICVR_IO_ERROR_OPEN, "%s: neither a folder nor a regular file", path);
    Series series;
    picvr_io_status status = gather_series(path, folder, series, err, err_size);
    if (status == PICVR_IO_OK) status = check_slices(series, err, err_size);
    Placement placement;
    if (status == PICVR_IO_OK) status = place_slices(series, placement, err, err_size);
    if (status != PICVR_IO_OK) return status;
    const Values values = choose_values(series);
    size_t bytes = 0;
    status = volume_bytes(path, series, values.type, bytes, err, err_size);
    if (status != PICVR_IO_OK) return status;
    const std::string warning = joined(series.warnings);
    unsigned char *data = nullptr;
    status = read_slices(path, series, values, bytes, data, err, err_size);
    if (status != PICVR_IO_OK) return status;
    return fill_volume(path, series, placement, values, warning, data, bytes, volume, err, err_size);
}

/* GDCM (as Debian builds it) prints its warnings and errors about every file it cannot
   parse to stderr; a folder holding other files would flood a program's output with
   them, and this reader reports its own messages.  GDCM's trace flags are process-wide:
   they are switched off while any load runs and put back as they were by the last
   load to finish. */
class QuietGdcm {
public:
    QuietGdcm() {
        std::lock_guard<std::mutex> lock(mutex_);
        if (users_++ == 0) {
            warning_ = gdcm::Trace::GetWarningFlag();
            error_ = gdcm::Trace::GetErrorFlag();
            debug_ = gdcm::Trace::GetDebugFlag();
            gdcm::Trace::SetWarning(false);
            gdcm::Trace::SetError(false);
            gdcm::Trace::SetDebug(false);
        }
    }
    ~QuietGdcm() {
        std::lock_guard<std::mutex> lock(mutex_);
        if (--users_ == 0) {
            gdcm::Trace::SetWarning(warning_);
            gdcm::Trace::SetError(error_);
            gdcm::Trace::SetDebug(debug_);
        }
    }
    QuietGdcm(const QuietGdcm &) = delete;
    QuietGdcm &operator=(const QuietGdcm &) = delete;

private:
    static std::mutex mutex_;
    static int users_;
    static bool warning_, error_, debug_;
};
std::mutex QuietGdcm::mutex_;
int QuietGdcm::users_ = 0;
bool QuietGdcm::warning_ = false, QuietGdcm::error_ = false, QuietGdcm::debug_ = false;

} // namespace

extern "C" picvr_io_status picvr_io_load_dicom(const char *path, picvr_io_volume *volume, char *err, size_t err_size) {
    if (volume) memset(volume, 0, sizeof *volume);
    if (!path || !volume) {
        picvr_io_set_error(err, err_size, "no path or output given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    picvr_io_status st;
    try {
        QuietGdcm quiet;
        st = load(path, volume, err, err_size);
    } catch (const std::bad_alloc &) {
        picvr_io_set_error(err, err_size, "%s: out of memory", path);
        st = PICVR_IO_ERROR_OUT_OF_MEMORY;
    } catch (const std::exception &e) {
        picvr_io_set_error(err, err_size, "%s: GDCM: %.200s", path, e.what());
        st = PICVR_IO_ERROR_READ;
    } catch (...) {
        picvr_io_set_error(err, err_size, "%s: GDCM failed", path);
        st = PICVR_IO_ERROR_READ;
    }
    /* load() frees its buffer on every failure, thrown ones included (read_slices), and
       hands it to *volume only past its last throwing call (fill_volume). */
    if (st != PICVR_IO_OK) memset(volume, 0, sizeof *volume);
    return st;
}

#else /* PICVR_IO_NO_DICOM: a build without GDCM */

extern "C" picvr_io_status picvr_io_load_dicom(const char *path, picvr_io_volume *volume, char *err, size_t err_size) {
    if (volume) memset(volume, 0, sizeof *volume);
    picvr_io_set_error(err, err_size, "%s: this build reads no DICOM (built without GDCM, PICVR_IO_NO_DICOM)",
                       path ? path : "(null)");
    return path && volume ? PICVR_IO_ERROR_UNSUPPORTED : PICVR_IO_ERROR_NULL_POINTER;
}

#endif /* PICVR_IO_NO_DICOM */

extern "C" int picvr_io_is_dicom(const char *path) {
    if (!path) return 0;
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) return 1;
    return picvr_io_has_suffix(path, ".dcm");
}
