/* dicom_slice.cpp - one DICOM file's header for the DICOM reader (io/dicom.h): the file
 * read and walked (io/dicom_walk.cpp), its data set up to Pixel Data parsed by
 * gdcm::Reader, and the attributes the reader uses read into a Slice (read_header).
 * Attribute values are parsed here from their bytes (strings with a locale-independent
 * number parser, US as binary), not through gdcm::Attribute, so that a malformed value
 * is a refusal with a message. */
#include "io/dicom.h"

#ifndef PICVR_IO_NO_DICOM

#include <string.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <istream>
#include <set>
#include <system_error>

#include <gdcmDataSet.h>
#include <gdcmReader.h>
#include <gdcmTag.h>

namespace picvr_io_dicom {
namespace {

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

} // namespace

std::string quote(const std::string &v, size_t n) {
    std::string q = v.substr(0, n);
    for (char &c : q)
        if ((unsigned char)c < 0x20 || (unsigned char)c > 0x7e) c = '?';
    return q;
}

int read_header(const std::string &path, Slice &s, std::string &why) {
    std::vector<char> bytes;
    if (read_file(path.c_str(), bytes, why) != PICVR_IO_OK) return -2;
    WalkResult walk;
    if (!walk_file(bytes, walk)) {
        if (!walk.pixel_truncated) {
            why = walk.error;
            return 0;
        }
        s.truncated = walk.error;
    }
    MemoryBuf buf(bytes.data(), bytes.size());
    std::istream in(&buf);
    gdcm::Reader r;
    r.SetStream(in);
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
    if (get_string(ds, 0x0008, 0x0060, v)) s.modality = quote(v, 7);
    if (get_us(ds, 0x0028, 0x0002, s.samples) < 0) return why = "malformed SamplesPerPixel", -1;
    if (get_us(ds, 0x0028, 0x0100, s.bits) != 1) return why = "no valid BitsAllocated", -1;
    if (get_us(ds, 0x0028, 0x0103, s.pixrep) < 0) return why = "malformed PixelRepresentation", -1;
    s.bits_stored = s.bits;
    if (get_us(ds, 0x0028, 0x0101, s.bits_stored) < 0) return why = "malformed BitsStored", -1;
    s.high_bit = s.bits_stored - 1;   /* the usual layout: stored bits at the bottom */
    if (get_us(ds, 0x0028, 0x0102, s.high_bit) < 0) return why = "malformed HighBit", -1;
    if (get_string(ds, 0x0028, 0x0008, v) && !v.empty()) {   /* NumberOfFrames (IS) */
        double f = 0;
        if (!parse_numbers(v, &f, 1) || f < 0 || f > 2147483647.0) return why = "malformed NumberOfFrames '" + quote(v, 32) + "'", -1;
        s.frames = (long)f;
    }
    if (get_string(ds, 0x0020, 0x0032, v) && !v.empty()) {
        if (!parse_numbers(v, s.ipp, 3)) return why = "malformed ImagePositionPatient '" + quote(v, 64) + "'", -1;
        s.has_ipp = true;
    }
    if (get_string(ds, 0x0020, 0x0037, v) && !v.empty()) {
        if (!parse_numbers(v, s.iop, 6)) return why = "malformed ImageOrientationPatient '" + quote(v, 96) + "'", -1;
        s.has_iop = true;
    }
    if (get_string(ds, 0x0028, 0x0030, v) && !v.empty()) {
        if (!parse_numbers(v, s.ps, 2) || !(s.ps[0] > 0) || !(s.ps[1] > 0))
            return why = "malformed PixelSpacing '" + quote(v, 48) + "' (two positive numbers)", -1;
        s.has_spacing = true;
    }
    if (get_string(ds, 0x0028, 0x1053, v) && !v.empty()) {
        if (!parse_numbers(v, &s.slope, 1) || s.slope == 0) return why = "malformed RescaleSlope '" + quote(v, 32) + "' (non-zero)", -1;
    }
    if (get_string(ds, 0x0028, 0x1052, v) && !v.empty()) {
        if (!parse_numbers(v, &s.intercept, 1)) return why = "malformed RescaleIntercept '" + quote(v, 32) + "'", -1;
    }
    if (get_string(ds, 0x0018, 0x0050, v) && !v.empty()) {
        double t = 0;
        if (parse_numbers(v, &t, 1) && t > 0) s.thickness = t;   /* informative only */
    }
    return 1;
}

} // namespace picvr_io_dicom

#endif /* PICVR_IO_NO_DICOM */
