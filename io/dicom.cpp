/* dicom.cpp - the DICOM series reader of picvr_io.h (picvr_io_load_dicom), through GDCM.
 *
 * Two passes.  First every regular file of the folder is parsed up to its pixel data
 * (gdcm::Reader::ReadUpToTag: headers only, cheap), files that do not parse or carry no
 * image (no Rows/Columns) are skipped, and the rest are grouped by SeriesInstanceUID.
 * The chosen series is then checked (one layout and one orientation for all slices),
 * sorted along the slice normal, and its geometry computed from the positions.  Only
 * after the volume's byte size is validated is it allocated, and the second pass reads
 * each slice whole (gdcm::Reader) and decodes its pixels with GDCM's codecs (every
 * transfer syntax GDCM has a codec for), from an image described by the attributes
 * checked here (see decode_slice).
 *
 * Attribute values are parsed here from their bytes (strings with a locale-independent
 * number parser, US as binary), not through gdcm::Attribute, so that a malformed value
 * is a refusal with a message rather than an assertion or a silent zero.  Every GDCM
 * call is inside try/catch: no exception leaves this file.
 */
#include "picvr_io.h"
#include "io/internal.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#ifndef PICVR_IO_NO_DICOM

#include <dirent.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <new>
#include <set>
#include <string>
#include <vector>

#include <gdcmDataSet.h>
#include <gdcmImage.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmReader.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

namespace {

const double kOrientationTolerance = 1e-4;   /* ImageOrientationPatient, per component */
const double kDuplicateTolerance = 1e-4;     /* mm along the normal: the same position */
const double kTiltToleranceDeg = 0.01;       /* below this, the slices stack along n */

/* A message with the file's path in front, into err. */
#define FAIL(status, ...)                                    \
    do {                                                     \
        picvr_io_set_error(err, err_size, __VA_ARGS__);      \
        return (status);                                     \
    } while (0)

struct Slice {
    std::string path;
    std::string series;             /* SeriesInstanceUID ("" when absent) */
    std::string photometric, modality;
    unsigned rows = 0, cols = 0, samples = 1, bits = 0, bits_stored = 0, high_bit = 0, pixrep = 0;
    long frames = 1;
    bool has_ipp = false, has_iop = false, has_spacing = false;
    double ipp[3] = {0, 0, 0};
    double iop[6] = {1, 0, 0, 0, 1, 0};
    double ps[2] = {1, 1};          /* PixelSpacing: row spacing, column spacing */
    double slope = 1, intercept = 0;
    double thickness = 0;           /* SliceThickness, for a one-slice volume only */
    double along_n = 0;             /* ImagePositionPatient . n */
    std::string bad;                /* a malformed attribute: refused if this series is read */
};

/* The value of a string-VR element, leading and trailing spaces and NULs removed;
   false when absent or not a byte value (a sequence). */
bool get_string(const gdcm::DataSet &ds, uint16_t g, uint16_t e, std::string &out) {
    const gdcm::Tag tag(g, e);
    if (!ds.FindDataElement(tag)) return false;
    const gdcm::DataElement &de = ds.GetDataElement(tag);
    const gdcm::ByteValue *bv = de.GetByteValue();
    if (!bv || !bv->GetPointer()) return false;
    const char *p = bv->GetPointer();
    size_t n = bv->GetLength();
    size_t a = 0;
    while (a < n && (p[a] == ' ' || p[a] == '\0')) a++;
    while (n > a && (p[n - 1] == ' ' || p[n - 1] == '\0')) n--;
    out.assign(p + a, n - a);
    return true;
}

/* Decimal strings "a\b\c" (DS, IS): exactly `count` finite numbers, each optionally
   surrounded by spaces and with a leading '+'.  std::from_chars: no locale. */
bool parse_numbers(const std::string &s, double *v, int count) {
    size_t at = 0;
    for (int i = 0; i < count; i++) {
        size_t end = s.find('\\', at);
        if (end == std::string::npos) end = s.size();
        if ((i == count - 1) != (end == s.size())) return false;   /* too few or too many */
        const char *b = s.data() + at, *e = s.data() + end;
        while (b < e && *b == ' ') b++;
        while (e > b && e[-1] == ' ') e--;
        if (b < e && *b == '+') b++;
        auto r = std::from_chars(b, e, v[i]);
        if (r.ec != std::errc() || r.ptr != e || !std::isfinite(v[i])) return false;
        at = end + 1;
    }
    return true;
}

/* A US value (binary; GDCM gives binary VRs in host order), or an IS/DS string where a
   writer used one.  Returns 0 absent, 1 read, -1 malformed. */
int get_us(const gdcm::DataSet &ds, uint16_t g, uint16_t e, unsigned &out) {
    const gdcm::Tag tag(g, e);
    if (!ds.FindDataElement(tag)) return 0;
    const gdcm::DataElement &de = ds.GetDataElement(tag);
    const gdcm::ByteValue *bv = de.GetByteValue();
    if (!bv || !bv->GetPointer()) return -1;
    const gdcm::VR vr = de.GetVR();
    if (vr == gdcm::VR::IS || vr == gdcm::VR::DS) {
        std::string s;
        double d = 0;
        if (!get_string(ds, g, e, s) || !parse_numbers(s, &d, 1) || d < 0 || d > 65535 || d != std::floor(d))
            return -1;
        out = (unsigned)d;
        return 1;
    }
    if (bv->GetLength() < 2) return -1;
    uint16_t v;
    memcpy(&v, bv->GetPointer(), 2);
    out = v;
    return 1;
}

/* Reads the attributes of one file (header only).  Returns 1 for an image, 0 when the
   file does not parse as DICOM or has no Rows/Columns (skipped in a folder), -1 for an
   image with a malformed attribute (message in why). */
int read_header(const std::string &path, Slice &s, std::string &why) {
    gdcm::Reader r;
    r.SetFileName(path.c_str());
    /* Pixel Data in the skipped tags: its value is neither read nor kept. */
    const std::set<gdcm::Tag> skip = {gdcm::Tag(0x7fe0, 0x0010)};
    if (!r.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010), skip)) {
        why = "not a DICOM file GDCM can parse";
        return 0;
    }
    const gdcm::DataSet &ds = r.GetFile().GetDataSet();
    s.path = path;
    std::string v;
    if (get_us(ds, 0x0028, 0x0010, s.rows) != 1 || get_us(ds, 0x0028, 0x0011, s.cols) != 1) {
        why = "no Rows and Columns: not an image";
        return 0;
    }
    get_string(ds, 0x0020, 0x000e, s.series);
    get_string(ds, 0x0028, 0x0004, s.photometric);
    if (get_string(ds, 0x0008, 0x0060, v)) s.modality = v;
    if (get_us(ds, 0x0028, 0x0002, s.samples) < 0) return why = "malformed SamplesPerPixel", -1;
    if (get_us(ds, 0x0028, 0x0100, s.bits) != 1) return why = "no valid BitsAllocated", -1;
    if (get_us(ds, 0x0028, 0x0103, s.pixrep) < 0) return why = "malformed PixelRepresentation", -1;
    s.bits_stored = s.bits;
    if (get_us(ds, 0x0028, 0x0101, s.bits_stored) < 0) return why = "malformed BitsStored", -1;
    s.high_bit = s.bits_stored - 1;   /* the usual layout: stored bits at the bottom */
    if (get_us(ds, 0x0028, 0x0102, s.high_bit) < 0) return why = "malformed HighBit", -1;
    if (get_string(ds, 0x0028, 0x0008, v) && !v.empty()) {   /* NumberOfFrames (IS) */
        double f = 0;
        if (!parse_numbers(v, &f, 1) || f < 0 || f > 2147483647.0) return why = "malformed NumberOfFrames '" + v.substr(0, 32) + "'", -1;
        s.frames = (long)f;
    }
    if (get_string(ds, 0x0020, 0x0032, v) && !v.empty()) {
        if (!parse_numbers(v, s.ipp, 3)) return why = "malformed ImagePositionPatient '" + v.substr(0, 64) + "'", -1;
        s.has_ipp = true;
    }
    if (get_string(ds, 0x0020, 0x0037, v) && !v.empty()) {
        if (!parse_numbers(v, s.iop, 6)) return why = "malformed ImageOrientationPatient '" + v.substr(0, 96) + "'", -1;
        s.has_iop = true;
    }
    if (get_string(ds, 0x0028, 0x0030, v) && !v.empty()) {
        if (!parse_numbers(v, s.ps, 2) || !(s.ps[0] > 0) || !(s.ps[1] > 0))
            return why = "malformed PixelSpacing '" + v.substr(0, 48) + "' (two positive numbers)", -1;
        s.has_spacing = true;
    }
    if (get_string(ds, 0x0028, 0x1053, v) && !v.empty()) {
        if (!parse_numbers(v, &s.slope, 1) || s.slope == 0) return why = "malformed RescaleSlope '" + v.substr(0, 32) + "' (non-zero)", -1;
    }
    if (get_string(ds, 0x0028, 0x1052, v) && !v.empty()) {
        if (!parse_numbers(v, &s.intercept, 1)) return why = "malformed RescaleIntercept '" + v.substr(0, 32) + "'", -1;
    }
    if (get_string(ds, 0x0018, 0x0050, v) && !v.empty()) {
        double t = 0;
        if (parse_numbers(v, &t, 1) && t > 0) s.thickness = t;   /* informative only */
    }
    return 1;
}

/* The regular files of a folder (symbolic links followed), sorted by name. */
picvr_io_status list_folder(const std::string &dir, std::vector<std::string> &files, char *err, size_t err_size) {
    DIR *d = opendir(dir.c_str());
    if (!d) FAIL(PICVR_IO_ERROR_OPEN, "%s: %s", dir.c_str(), strerror(errno));
    std::vector<std::string> names;
    try {
        while (struct dirent *e = readdir(d)) {
            if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
            std::string p = dir + "/" + e->d_name;
            struct stat st;
            if (stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode)) names.push_back(p);
        }
    } catch (...) {
        closedir(d);
        throw;
    }
    closedir(d);
    std::sort(names.begin(), names.end());
    files.swap(names);
    return PICVR_IO_OK;
}

double dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

bool normalize(double *v) {
    double len = std::sqrt(dot(v, v));
    if (!(len > 1e-6) || !std::isfinite(len)) return false;
    for (int c = 0; c < 3; c++) v[c] /= len;
    return true;
}

bool close_to(double a, double b, double rel) { return std::fabs(a - b) <= rel * std::max(1.0, std::fabs(a)); }

/* The first difference of s from the reference slice r in what all slices must share,
   or "" when none. */
std::string layout_difference(const Slice &r, const Slice &s) {
    char buf[256];
    if (s.rows != r.rows || s.cols != r.cols) {
        snprintf(buf, sizeof buf, "%u rows x %u columns, not %u x %u", s.rows, s.cols, r.rows, r.cols);
        return buf;
    }
    if (s.bits != r.bits || s.pixrep != r.pixrep) {
        snprintf(buf, sizeof buf, "BitsAllocated %u PixelRepresentation %u, not %u %u", s.bits, s.pixrep, r.bits, r.pixrep);
        return buf;
    }
    if (s.has_spacing != r.has_spacing || !close_to(s.ps[0], r.ps[0], 1e-4) || !close_to(s.ps[1], r.ps[1], 1e-4)) {
        snprintf(buf, sizeof buf, "PixelSpacing %g\\%g, not %g\\%g", s.ps[0], s.ps[1], r.ps[0], r.ps[1]);
        return buf;
    }
    if (s.has_iop != r.has_iop) return "ImageOrientationPatient present in one slice only";
    for (int i = 0; i < 6; i++)
        if (std::fabs(s.iop[i] - r.iop[i]) > kOrientationTolerance) {
            snprintf(buf, sizeof buf, "ImageOrientationPatient %g\\%g\\%g\\%g\\%g\\%g, not %g\\%g\\%g\\%g\\%g\\%g",
                     s.iop[0], s.iop[1], s.iop[2], s.iop[3], s.iop[4], s.iop[5],
                     r.iop[0], r.iop[1], r.iop[2], r.iop[3], r.iop[4], r.iop[5]);
            return buf;
        }
    if (s.photometric != r.photometric) return "PhotometricInterpretation " + s.photometric.substr(0, 16) + ", not " + r.photometric.substr(0, 16);
    return "";
}

/* Copies n stored values of the given type into floats, rescaled. */
void to_float(const unsigned char *in, float *out, size_t n, unsigned bits, unsigned pixrep, double slope, double intercept) {
    for (size_t i = 0; i < n; i++) {
        double v;
        if (bits == 8) v = pixrep ? (double)(int8_t)in[i] : (double)in[i];
        else if (bits == 16) {
            uint16_t u;
            memcpy(&u, in + 2 * i, 2);
            v = pixrep ? (double)(int16_t)u : (double)u;
        } else {
            uint32_t u;
            memcpy(&u, in + 4 * i, 4);
            v = pixrep ? (double)(int32_t)u : (double)u;
        }
        out[i] = (float)(v * slope + intercept);
    }
}

/* GDCM accepts native pixel data cut short by the end of the file (the rest of its
   buffer is left as zeros), so the reader checks the file itself: the first Pixel Data
   element header (explicit or implicit VR, either byte order) announcing `length` bytes
   must be followed by that many bytes.  Returns false only when such a header is found
   and the file ends early; a header not found (a layout not recognised here) is left to
   GDCM's own checks. */
bool native_pixel_data_complete(const char *path, uint32_t length) {
    FILE *f = fopen(path, "rb");
    if (!f) return false;
    std::vector<unsigned char> b;
    unsigned char chunk[65536];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) b.insert(b.end(), chunk, chunk + n);
    const bool read_error = ferror(f) != 0;
    fclose(f);
    if (read_error) return false;
    const size_t size = b.size();
    auto le32 = [&](size_t i) { return (uint32_t)b[i] | (uint32_t)b[i + 1] << 8 | (uint32_t)b[i + 2] << 16 | (uint32_t)b[i + 3] << 24; };
    auto be32 = [&](size_t i) { return (uint32_t)b[i + 3] | (uint32_t)b[i + 2] << 8 | (uint32_t)b[i + 1] << 16 | (uint32_t)b[i] << 24; };
    for (size_t i = 0; i + 8 <= size; i++) {
        const bool le = b[i] == 0xe0 && b[i + 1] == 0x7f && b[i + 2] == 0x10 && b[i + 3] == 0x00;
        const bool be = b[i] == 0x7f && b[i + 1] == 0xe0 && b[i + 2] == 0x00 && b[i + 3] == 0x10;
        if (!le && !be) continue;
        const bool explicit_vr = (b[i + 4] == 'O' && (b[i + 5] == 'W' || b[i + 5] == 'B')) || (b[i + 4] == 'U' && b[i + 5] == 'N');
        size_t value_at;
        uint32_t announced;
        if (explicit_vr) {
            if (i + 12 > size) continue;
            announced = le ? le32(i + 8) : be32(i + 8);
            value_at = i + 12;
        } else if (le) {
            announced = le32(i + 4);
            value_at = i + 8;
        } else {
            continue;
        }
        if (announced != length) continue;
        return size - value_at >= length;
    }
    return true;
}

/* Decodes one slice into dst (slice_bytes bytes).  The file is read with gdcm::Reader
   and the image built here from the attributes this reader parsed and checked, then
   decoded by GDCM's codecs (gdcm::Bitmap::GetBuffer): gdcm::ImageReader is not used
   because its geometry helpers (gdcm::ImageHelper) assert on malformed attributes
   (e.g. a Frame Increment Pointer without Number of Frames aborts the process in
   Debian's build, whose assertions are on), and this reader needs none of them. */
picvr_io_status decode_slice(const Slice &s, unsigned char *dst, size_t slice_bytes, char *err, size_t err_size) {
    const char *p = s.path.c_str();
    gdcm::Reader r;
    r.SetFileName(p);
    if (!r.Read()) FAIL(PICVR_IO_ERROR_READ, "%s: GDCM cannot read the file (truncated or corrupt?)", p);
    const gdcm::File &file = r.GetFile();
    const gdcm::DataSet &ds = file.GetDataSet();
    const gdcm::Tag pixel_tag(0x7fe0, 0x0010);
    if (!ds.FindDataElement(pixel_tag) || ds.GetDataElement(pixel_tag).IsEmpty())
        FAIL(PICVR_IO_ERROR_TRUNCATED, "%s: no pixel data", p);
    const gdcm::DataElement &pd = ds.GetDataElement(pixel_tag);
    const gdcm::TransferSyntax ts = file.GetHeader().GetDataSetTransferSyntax();
    if (!ts.IsValid()) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: unknown transfer syntax", p);
    if (ts.IsEncapsulated()) {
        if (!pd.GetSequenceOfFragments())
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: transfer syntax %s without encapsulated pixel data", p, gdcm::TransferSyntax::GetTSString(ts));
    } else {
        /* Native pixel data: its length is known, a short one is a truncated file. */
        const gdcm::ByteValue *bv = pd.GetByteValue();
        if (!bv) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: encapsulated pixel data in native transfer syntax %s", p, gdcm::TransferSyntax::GetTSString(ts));
        if (bv->GetLength() < slice_bytes)
            FAIL(PICVR_IO_ERROR_TRUNCATED, "%s: truncated pixel data: %lu bytes, the slice needs %zu", p,
                 (unsigned long)bv->GetLength(), slice_bytes);
        if (ts != gdcm::TransferSyntax::DeflatedExplicitVRLittleEndian && !native_pixel_data_complete(p, bv->GetLength()))
            FAIL(PICVR_IO_ERROR_TRUNCATED, "%s: truncated: the file ends inside its pixel data", p);
    }
    gdcm::Image img;
    img.SetNumberOfDimensions(2);
    img.SetDimension(0, s.cols);
    img.SetDimension(1, s.rows);
    img.SetPixelFormat(gdcm::PixelFormat(1, (unsigned short)s.bits, (unsigned short)s.bits_stored,
                                         (unsigned short)s.high_bit, (unsigned short)s.pixrep));
    img.SetPhotometricInterpretation(s.photometric == "MONOCHROME1" ? gdcm::PhotometricInterpretation::MONOCHROME1
                                                                   : gdcm::PhotometricInterpretation::MONOCHROME2);
    img.SetTransferSyntax(ts);
    img.SetDataElement(pd);
    if (img.GetBufferLength() != slice_bytes)
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: GDCM's buffer is %lu bytes, the slice %zu", p, img.GetBufferLength(), slice_bytes);
    if (!img.GetBuffer(reinterpret_cast<char *>(dst)))
        FAIL(PICVR_IO_ERROR_READ, "%s: GDCM cannot decode the pixel data (transfer syntax %s)", p, gdcm::TransferSyntax::GetTSString(ts));
    return PICVR_IO_OK;
}

std::string fmt(const char *f, double a, double b = 0) {
    char buf[128];
    snprintf(buf, sizeof buf, f, a, b);
    return buf;
}

picvr_io_status load(const char *path, picvr_io_volume *volume, char *err, size_t err_size) {
    struct stat st;
    if (stat(path, &st) != 0) FAIL(PICVR_IO_ERROR_OPEN, "%s: %s", path, strerror(errno));
    const bool folder = S_ISDIR(st.st_mode);
    if (!folder && !S_ISREG(st.st_mode)) FAIL(PICVR_IO_ERROR_OPEN, "%s: neither a folder nor a regular file", path);
    std::vector<std::string> warnings;

    /* ---- pass 1: headers, grouped by series ---- */
    std::string dir;
    std::string want_series;
    if (folder) {
        dir = path;
        while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
    } else {
        const char *slash = strrchr(path, '/');
        dir = slash ? std::string(path, slash == path ? 1 : (size_t)(slash - path)) : std::string(".");
        Slice s;
        std::string why;
        int r = read_header(path, s, why);
        if (r <= 0) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: %s", path, why.c_str());
        want_series = s.series;
    }
    std::vector<std::string> files;
    picvr_io_status status = list_folder(dir, files, err, err_size);
    if (status != PICVR_IO_OK) return status;
    if (files.empty()) FAIL(PICVR_IO_ERROR_OPEN, "%s: no file in the folder", dir.c_str());
    std::map<std::string, std::vector<Slice>> series;
    size_t skipped = 0;
    for (const std::string &f : files) {
        Slice s;
        std::string why;
        int r = read_header(f, s, why);
        if (r == 0) {
            skipped++;
            continue;
        }
        if (!folder && s.series != want_series) continue;
        if (r < 0) s.bad = why;
        series[s.series].push_back(std::move(s));
    }
    if (series.empty()) {
        if (!folder) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: its folder %s no longer holds its series", path, dir.c_str());
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: no DICOM image among its %zu files", dir.c_str(), files.size());
    }
    /* The largest series; on a tie the first UID (std::map order): deterministic. */
    auto chosen = series.begin();
    for (auto it = series.begin(); it != series.end(); ++it)
        if (it->second.size() > chosen->second.size()) chosen = it;
    std::vector<Slice> &slices = chosen->second;
    if (folder && series.size() > 1) {
        char buf[200];
        snprintf(buf, sizeof buf, "series %.64s (%zu slices) read, %zu other series in the folder ignored",
                 chosen->first.c_str(), slices.size(), series.size() - 1);
        warnings.push_back(buf);
    }
    if (folder && skipped) warnings.push_back(std::to_string(skipped) + " files not DICOM images skipped");

    /* ---- checks: one layout for all slices ---- */
    const Slice &ref = slices[0];
    for (const Slice &s : slices) {
        const char *p = s.path.c_str();
        if (!s.bad.empty()) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: %s", p, s.bad.c_str());
        if (s.frames > 1) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: a multi-frame image (%ld frames) is not read: one frame per file", p, s.frames);
        if (s.samples != 1) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: SamplesPerPixel %u: only grey images (1) are read", p, s.samples);
        if (s.photometric != "MONOCHROME1" && s.photometric != "MONOCHROME2")
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: PhotometricInterpretation '%.32s': only MONOCHROME1/2 are read", p, s.photometric.c_str());
        if (s.bits != 8 && s.bits != 16 && s.bits != 32)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: BitsAllocated %u: 8, 16 or 32 are read", p, s.bits);
        if (s.bits_stored < 1 || s.bits_stored > s.bits || s.high_bit + 1 < s.bits_stored || s.high_bit >= s.bits)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: BitsStored %u HighBit %u do not fit BitsAllocated %u", p, s.bits_stored, s.high_bit, s.bits);
        if (s.pixrep > 1) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: PixelRepresentation %u (0 or 1)", p, s.pixrep);
        if (s.rows < 1 || s.cols < 1 || s.rows > PICVR_IO_MAX_DIM || s.cols > PICVR_IO_MAX_DIM)
            FAIL(PICVR_IO_ERROR_BAD_DIMS, "%s: %u rows x %u columns: each must be 1..%u", p, s.rows, s.cols, PICVR_IO_MAX_DIM);
        std::string d = layout_difference(ref, s);
        if (!d.empty()) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: %s (of %s): all slices must agree", p, d.c_str(), ref.path.c_str());
    }
    const size_t nz = slices.size();
    if (nz > PICVR_IO_MAX_DIM) FAIL(PICVR_IO_ERROR_BAD_DIMS, "%s: %zu slices, at most %u are read", dir.c_str(), nz, PICVR_IO_MAX_DIM);

    /* ---- geometry ---- */
    double row[3] = {ref.iop[0], ref.iop[1], ref.iop[2]}, col[3] = {ref.iop[3], ref.iop[4], ref.iop[5]};
    if (!normalize(row) || !normalize(col) || std::fabs(dot(row, col)) > 1e-3)
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: ImageOrientationPatient: two orthogonal non-zero cosines are needed", ref.path.c_str());
    double n[3] = {row[1] * col[2] - row[2] * col[1], row[2] * col[0] - row[0] * col[2], row[0] * col[1] - row[1] * col[0]};
    normalize(n);
    if (!ref.has_iop) warnings.push_back("no ImageOrientationPatient: axial identity assumed");
    if (!ref.has_spacing) warnings.push_back("no PixelSpacing: 1 mm assumed");
    for (Slice &s : slices) {
        if (!s.has_ipp && nz > 1)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: no ImagePositionPatient: slices cannot be ordered", s.path.c_str());
        s.along_n = dot(s.ipp, n);
    }
    if (!ref.has_ipp) warnings.push_back("no ImagePositionPatient: origin 0 assumed");
    std::stable_sort(slices.begin(), slices.end(), [](const Slice &a, const Slice &b) { return a.along_n < b.along_n; });
    double axis_z[3] = {n[0], n[1], n[2]};
    double slice_spacing = 1.0;
    if (nz > 1) {
        std::vector<double> diffs(nz - 1);
        for (size_t i = 0; i + 1 < nz; i++) {
            diffs[i] = slices[i + 1].along_n - slices[i].along_n;
            if (!(diffs[i] > kDuplicateTolerance))
                FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s and %s: duplicate slice position (%g mm along the normal)",
                     slices[i].path.c_str(), slices[i + 1].path.c_str(), slices[i].along_n);
        }
        std::vector<double> sorted = diffs;
        std::sort(sorted.begin(), sorted.end());
        const size_t m = sorted.size();
        double median = m % 2 ? sorted[m / 2] : 0.5 * (sorted[m / 2 - 1] + sorted[m / 2]);
        const double tol = std::max(0.01 * median, 0.01);
        if (sorted.front() < median - tol || sorted.back() > median + tol)
            warnings.push_back(fmt("uneven slice spacing (%.4g .. %.4g mm), the median used", sorted.front(), sorted.back()));
        /* Gantry tilt: the slices stack along first -> last, not along n. */
        double t[3];
        for (int c = 0; c < 3; c++) t[c] = slices[nz - 1].ipp[c] - slices[0].ipp[c];
        normalize(t);   /* non-zero: the projections differ */
        double cosang = std::min(1.0, dot(t, n));
        double angle = std::acos(cosang) * 180.0 / 3.14159265358979323846;
        if (angle > kTiltToleranceDeg) {
            if (angle >= 60.0)
                FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: the slices stack %.1f degrees off their normal: not one volume",
                     dir.c_str(), angle);
            warnings.push_back(fmt("gantry tilt of %.3g degrees: the z axis follows the slice positions, "
                                   "not orthogonal to the slices", angle));
            for (int c = 0; c < 3; c++) axis_z[c] = t[c];
            median /= cosang;   /* the step along t that advances `median` along n */
        }
        slice_spacing = median;
    } else if (ref.thickness > 0) {
        slice_spacing = ref.thickness;
        warnings.push_back(fmt("one slice: its SliceThickness %g mm taken as the slice spacing", ref.thickness));
    }

    /* ---- values ---- */
    bool rescale_varies = false;
    for (const Slice &s : slices)
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

    picvr_io_layout layout = {{ref.cols, ref.rows, (uint32_t)nz}, type};
    size_t bytes = 0;
    char lerr[160];
    status = picvr_io_layout_bytes(&layout, &bytes, lerr, sizeof lerr);
    if (status != PICVR_IO_OK) FAIL(status, "%s: %s", path, lerr);
    std::string w;
    for (const std::string &s : warnings) w += (w.empty() ? "" : "; ") + s;
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

    volume->dims[0] = ref.cols;
    volume->dims[1] = ref.rows;
    volume->dims[2] = (uint32_t)nz;
    volume->type = type;
    volume->data = data;
    volume->size = bytes;
    volume->spacing[0] = (float)ref.ps[1];   /* along a row: the column spacing */
    volume->spacing[1] = (float)ref.ps[0];
    volume->spacing[2] = (float)slice_spacing;
    for (int c = 0; c < 3; c++) {
        volume->origin[c] = (float)slices[0].ipp[c];
        volume->direction[0 + c] = (float)row[c];
        volume->direction[3 + c] = (float)col[c];
        volume->direction[6 + c] = (float)axis_z[c];
    }
    volume->value_scale = rescale_varies ? 1.0 : ref.slope;
    volume->value_offset = rescale_varies ? 0.0 : ref.intercept;
    snprintf(volume->modality, sizeof volume->modality, "%s", ref.modality.c_str());
    snprintf(volume->warning, sizeof volume->warning, "%s", w.c_str());
    for (int i = 0; i < 3; i++)
        if (!(volume->spacing[i] > 0.0f) || !std::isfinite(volume->spacing[i]) || !std::isfinite(volume->origin[i])) {
            picvr_io_free(volume);
            FAIL(PICVR_IO_ERROR_BAD_DIMS, "%s: a spacing or position beyond float", path);
        }
    return PICVR_IO_OK;
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
    /* load() frees its buffer on every failure, thrown ones included, and hands it to
       *volume only past its last throwing call. */
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
