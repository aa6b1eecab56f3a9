/* dicom.cpp - the DICOM series reader of picvr_io.h (picvr_io_load_dicom), through GDCM.
 *
 * Two passes.  First every regular file of the folder is read and its header parsed
 * (gdcm::Reader::ReadUpToTag, Pixel Data skipped); files that are not DICOM or carry no
 * image (no Rows/Columns) are skipped, the rest grouped by SeriesInstanceUID.  The
 * chosen series is checked (one layout and one orientation for all slices), sorted
 * along the slice normal, and its geometry computed from the positions.  Only after the
 * volume's byte size is validated is it allocated; the second pass reads each slice
 * whole and decodes its pixels with GDCM's codecs (native, JPEG, JPEG-LS, JPEG 2000,
 * RLE), from an image described by the attributes checked here (decode_slice).
 *
 * GDCM 3.0.21 as Debian builds it is not safe on hostile input by itself: it allocates
 * what lengths announce, its assertions are compiled in (an abort), several codecs
 * trust the DICOM header over their stream or the reverse, and its JPEG fallback runs
 * an external program.  So every file is first walked here (class Walker: structure,
 * lengths, nesting) and every compressed stream's own header checked against the DICOM
 * header before GDCM sees them; the places where GDCM is avoided or fenced say why.
 * Attribute values are parsed here from their bytes (strings with a locale-independent
 * number parser, US as binary), not through gdcm::Attribute, so that a malformed value
 * is a refusal with a message.  Every GDCM call is inside try/catch: no exception leaves
 * this file.
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
#include <istream>
#include <set>
#include <streambuf>
#include <string>
#include <vector>

#include <zlib.h>

#include <gdcmDataSet.h>
#include <gdcmImage.h>
#include <gdcmJPEG2000Codec.h>
#include <gdcmJPEGCodec.h>
#include <gdcmJPEGLSCodec.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmRLECodec.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfFragments.h>
#include <gdcmSwapCode.h>
#include <gdcmTag.h>
#include <gdcmTransferSyntax.h>
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
    std::string truncated;          /* pixel data cut short: likewise */
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

/* At most n characters of a file's string for a message, non-printable bytes as '?'. */
std::string quote(const std::string &v, size_t n) {
    std::string q = v.substr(0, n);
    for (char &c : q)
        if ((unsigned char)c < 0x20 || (unsigned char)c > 0x7e) c = '?';
    return q;
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

/* ---- a structural check of the file before GDCM sees it ----------------------------
 * GDCM allocates what an element's length announces before reading it (a 1 KB file
 * announcing a 4 GB element makes it allocate 4 GB), and Debian builds it with its
 * assertions on, which abort the process on some malformed streams.  So every file is
 * first read into memory and walked here: the meta group, then the data set in the
 * transfer syntax the meta group names (inflated first for the deflated one), every
 * element's length checked against the bytes left in its container, sequences and items
 * followed to their delimiters (at most kMaxDepth deep), undefined lengths allowed only
 * where DICOM allows them (SQ, UN, encapsulated Pixel Data).  GDCM then reads the same
 * bytes from memory.  A file GDCM's heuristics would have read in spite of a malformed
 * structure (an unknown VR, implicit elements in an explicit data set) is refused. */

const int kMaxDepth = 16;
const size_t kMaxFileBytes = (size_t)1 << 32;        /* one slice file at most (4 GiB) */
const size_t kMaxInflatedBytes = (size_t)1 << 30;    /* a deflated data set, inflated */
/* The largest volume this reader allocates.  A header may claim any size, and a slice of
   a few kB, compressed, can claim gigabytes legitimately; the fuzz build lowers it (make
   fuzz) so that such claims are refused instead of allocated. */
#ifndef PICVR_IO_DICOM_MAX_BYTES
#define PICVR_IO_DICOM_MAX_BYTES ((uint64_t)16 << 30)
#endif

class Walker {
public:
    std::string error;            /* why the walk failed */
    bool truncated = false;       /* it failed because the bytes ran out */
    bool pixel_truncated = false; /* ... inside the top-level Pixel Data, all else complete */

    /* Walks a whole file; false with error set when it is refused. */
    bool walk_file(const std::vector<char> &file) {
        const unsigned char *b = reinterpret_cast<const unsigned char *>(file.data());
        const size_t n = file.size();
        data_ = b;
        big_ = false;
        implicit_ = false;
        /* A DICOM file (PS3.10): 128 bytes, "DICM", the meta group.  Without them GDCM
           guesses the encoding, and its guessing asserts on unexpected first tags: bare
           data sets (ACR-NEMA, files written without meta group) are refused. */
        if (n < 132 || memcmp(b + 128, "DICM", 4) != 0) {
            error = "not a DICOM file (no DICM magic at byte 128)";
            return false;
        }
        size_t pos = 132;
        /* The meta group, explicit VR little endian, opening with its group length (UL):
           GDCM's reader takes another path, a guessing one, otherwise. */
        if (n - pos < 12 || u16(pos) != 0x0002 || u16(pos + 2) != 0x0000 || b[pos + 4] != 'U' || b[pos + 5] != 'L' || u16(pos + 6) != 4)
            return fail(pos, "no meta group length (0002,0000) UL after the DICM magic", n - pos < 12);
        std::string ts;
        while (n - pos >= 8 && u16(pos) == 0x0002) {
            size_t value, len;
            if (!element_header(pos, n, value, len)) return false;
            if (b[pos + 4] == 'S' && b[pos + 5] == 'Q') return fail(pos, "a sequence in the meta group", false);
            if (len == kUndefined || len > n - value) return fail(pos, "a meta element longer than the file", len != kUndefined);
            if (u16(pos + 2) == 0x0010) ts.assign(reinterpret_cast<const char *>(b + value), len);
            pos = value + len;
        }
        /* GDCM reads the tag after the meta group unchecked (an assertion at the end of
           the file): a data set of at least one element must follow. */
        if (n - pos < 8) return fail(pos, "no data set after the meta group", true);
        /* The encoding as GDCM takes it from the transfer syntax UID (up to its first NUL). */
        const gdcm::TransferSyntax tsx(gdcm::TransferSyntax::GetTSType(ts.c_str()));
        if (!tsx.IsValid()) return fail(pos, "a missing or unknown transfer syntax in the meta group", false);
        implicit_ = tsx.GetNegociatedType() == gdcm::TransferSyntax::Implicit;
        big_ = tsx.GetSwapCode() == gdcm::SwapCode::BigEndian;
        if (implicit_ && big_) return fail(pos, "implicit VR big endian", false);
        if (tsx == gdcm::TransferSyntax::DeflatedExplicitVRLittleEndian) return walk_deflated(b + pos, n - pos);
        return dataset(pos, n, 0, false);
    }

private:
    static const size_t kUndefined = 0xffffffffu;
    const unsigned char *data_ = nullptr;
    bool big_ = false, implicit_ = false;
    std::vector<unsigned char> inflated_;

    unsigned u16(size_t i) const { return big_ ? (unsigned)data_[i] << 8 | data_[i + 1] : (unsigned)data_[i + 1] << 8 | data_[i]; }
    size_t u32(size_t i) const {
        return big_ ? (size_t)data_[i] << 24 | (size_t)data_[i + 1] << 16 | (size_t)data_[i + 2] << 8 | data_[i + 3]
                    : (size_t)data_[i + 3] << 24 | (size_t)data_[i + 2] << 16 | (size_t)data_[i + 1] << 8 | data_[i];
    }

    static bool known_vr(const unsigned char *v) {
        static const char *const vrs[] = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FL", "FD", "IS", "LO", "LT", "OB", "OD", "OF",
                                          "OL", "OV", "OW", "PN", "SH", "SL", "SQ", "SS", "ST", "SV", "TM", "UC", "UI", "UL", "UN",
                                          "UR", "US", "UT", "UV"};
        for (const char *vr : vrs)
            if (v[0] == (unsigned char)vr[0] && v[1] == (unsigned char)vr[1]) return true;
        return false;
    }
    static bool long_vr(const unsigned char *v) {   /* 2 reserved bytes and a 32-bit length */
        static const char *const vrs[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
        for (const char *vr : vrs)
            if (v[0] == (unsigned char)vr[0] && v[1] == (unsigned char)vr[1]) return true;
        return false;
    }

    bool fail(size_t pos, const char *what, bool out_of_bytes) {
        char buf[200];
        snprintf(buf, sizeof buf, "%s at byte %zu%s: %s", out_of_bytes ? "the file ends early" : "malformed DICOM", pos,
                 data_ == inflated_.data() && data_ ? " of the inflated data set" : "", what);
        error = buf;
        truncated = out_of_bytes;
        return false;
    }

    /* Reads the header of the element at pos (tag, VR if explicit, length): value
       start and length (kUndefined for an undefined length). */
    bool element_header(size_t pos, size_t end, size_t &value, size_t &len) {
        if (end - pos < 8) return fail(pos, "an element header cut short", true);
        if (implicit_) {   /* (the meta group, explicit, is walked before implicit_ is set) */
            len = u32(pos + 4);
            value = pos + 8;
            return true;
        }
        const unsigned char *vr = data_ + pos + 4;
        if (!known_vr(vr)) return fail(pos, "an unknown VR (or implicit VR in an explicit data set)", false);
        if (long_vr(vr)) {
            if (end - pos < 12) return fail(pos, "an element header cut short", true);
            len = u32(pos + 8);
            value = pos + 12;
        } else {
            len = u16(pos + 6);
            value = pos + 8;
        }
        return true;
    }

    /* The elements of a data set from pos (advanced) to end; with until_delimiter, an
       undefined-length item's, up to and past its delimiter. */
    bool dataset(size_t &pos, size_t end, int depth, bool until_delimiter) {
        if (depth > kMaxDepth) return fail(pos, "sequences nested too deep", false);
        const bool top = depth == 0;
        while (pos < end) {
            /* Stray bytes after the last element are refused too: GDCM fails on them and
               retries in a recovery mode that asserts. */
            if (end - pos < 8) return fail(pos, "an element header cut short", true);
            const unsigned group = u16(pos), elem = u16(pos + 2);
            /* Group 2 belongs to the meta group alone: inside the data set GDCM reads it in
               the data set's encoding, where a walker taking it as the meta group's would
               not (an implicit length of gigabytes). */
            if (group == 0x0002) return fail(pos, "a meta group element (0002,xxxx) inside the data set", false);
            if (group == 0xfffe) {
                if (until_delimiter && elem == 0xe00d && u32(pos + 4) == 0) {
                    pos += 8;
                    return true;
                }
                return fail(pos, "an item tag where an element was expected", false);
            }
            size_t value, len;
            if (!element_header(pos, end, value, len)) return false;
            const bool pixel_data = group == 0x7fe0 && elem == 0x0010;
            const unsigned char *vr = implicit_ ? nullptr : data_ + pos + 4;
            const bool sq = vr && vr[0] == 'S' && vr[1] == 'Q';
            const bool un = vr && vr[0] == 'U' && vr[1] == 'N';
            /* GDCM asserts that Pixel Data is OB, OW or UN, and not a sequence */
            if (pixel_data && vr && !(vr[0] == 'O' && (vr[1] == 'B' || vr[1] == 'W')) && !un)
                return fail(pos, "Pixel Data of a VR other than OB, OW and UN", false);
            if (len == kUndefined) {
                pos = value;
                if (pixel_data) {
                    if (!fragments(pos, end, top)) return false;
                    continue;
                }
                if (vr && !sq && !un) return fail(pos, "an undefined length outside SQ, UN and Pixel Data", false);
                /* UN of undefined length holds implicit VR little endian items (CP-246) */
                const bool saved_implicit = implicit_, saved_big = big_;
                if (un) implicit_ = true, big_ = false;
                const bool ok = sequence(pos, end, depth + 1, true);
                implicit_ = saved_implicit, big_ = saved_big;
                if (!ok) return false;
                continue;
            }
            if (len > end - value) {
                if (pixel_data && top) pixel_truncated = true;
                char what[96];
                snprintf(what, sizeof what, "element (%04x,%04x) announces %zu bytes, %zu are left", group, elem, len, end - value);
                return fail(pos, what, true);
            }
            /* GDCM parses an implicit VR element of defined length whose value opens with an
               item tag as a sequence (asserting that it is not Pixel Data): so does this */
            const bool items = sq || (implicit_ && len >= 4 && u16(value) == 0xfffe && u16(value + 2) == 0xe000);
            if (items && pixel_data) return fail(pos, "Pixel Data holding items", false);
            if (items) {
                size_t p = value;
                if (!sequence(p, value + len, depth + 1, false)) return false;
            }
            pos = value + len;
        }
        if (until_delimiter) return fail(pos, "an item without its delimiter", true);
        return true;
    }

    /* The items of a sequence from pos (advanced) to end; with `undefined`, up to and
       past the sequence delimiter. */
    bool sequence(size_t &pos, size_t end, int depth, bool undefined) {
        if (depth > kMaxDepth) return fail(pos, "sequences nested too deep", false);
        while (pos < end || undefined) {
            if (end - pos < 8) return fail(pos, "a sequence cut short", true);
            const unsigned group = u16(pos), elem = u16(pos + 2);
            const size_t len = u32(pos + 4);
            if (group == 0xfffe && elem == 0xe0dd && undefined) {
                if (len != 0) return fail(pos, "a sequence delimiter with a length", false);
                pos += 8;
                return true;
            }
            if (group != 0xfffe || elem != 0xe000) return fail(pos, "a sequence holding something else than items", false);
            pos += 8;
            if (len == kUndefined) {
                if (!dataset(pos, end, depth + 1, true)) return false;
                continue;
            }
            if (len > end - pos) return fail(pos, "an item longer than its sequence", true);
            size_t p = pos;
            if (!dataset(p, pos + len, depth + 1, false)) return false;
            pos += len;
        }
        return true;
    }

    /* Encapsulated Pixel Data: items of defined length up to the sequence delimiter. */
    bool fragments(size_t &pos, size_t end, bool top) {
        for (;;) {
            if (end - pos < 8) {
                if (top) pixel_truncated = true;
                return fail(pos, "encapsulated pixel data cut short", true);
            }
            const unsigned group = u16(pos), elem = u16(pos + 2);
            const size_t len = u32(pos + 4);
            if (group == 0xfffe && elem == 0xe0dd) {
                if (len != 0) return fail(pos, "a sequence delimiter with a length", false);
                pos += 8;
                return true;
            }
            if (group != 0xfffe || elem != 0xe000 || len == kUndefined)
                return fail(pos, "encapsulated pixel data holding something else than fragments", false);
            if (len > end - pos - 8) {
                if (top) pixel_truncated = true;
                return fail(pos, "a pixel data fragment longer than the file", true);
            }
            pos += 8 + len;
        }
    }

    /* The deflated transfer syntax: the data set after the meta group is a raw deflate
       stream; walked once inflated (at most kMaxInflatedBytes). */
    bool walk_deflated(const unsigned char *in, size_t n) {
        z_stream z;
        memset(&z, 0, sizeof z);
        if (inflateInit2(&z, -MAX_WBITS) != Z_OK) return fail(0, "zlib", false);
        std::vector<unsigned char> out(n < (kMaxInflatedBytes / 8) ? n * 8 + 4096 : kMaxInflatedBytes);
        z.next_in = const_cast<unsigned char *>(in);
        size_t consumed = 0, produced = 0;
        int zr = Z_OK;
        while (zr == Z_OK) {
            if (produced == out.size()) {
                if (out.size() >= kMaxInflatedBytes) break;
                out.resize(std::min(out.size() * 2, kMaxInflatedBytes));
            }
            const size_t in_chunk = std::min(n - consumed, (size_t)1 << 30), out_chunk = std::min(out.size() - produced, (size_t)1 << 30);
            z.next_in = const_cast<unsigned char *>(in + consumed);
            z.avail_in = (uInt)in_chunk;
            z.next_out = out.data() + produced;
            z.avail_out = (uInt)out_chunk;
            zr = inflate(&z, Z_NO_FLUSH);
            consumed += in_chunk - z.avail_in;
            produced += out_chunk - z.avail_out;
            if (zr == Z_BUF_ERROR && consumed == n) break;   /* input ended early */
            if (zr == Z_BUF_ERROR && z.avail_out == 0) zr = Z_OK;
        }
        inflateEnd(&z);
        if (zr != Z_STREAM_END) {
            if (produced >= kMaxInflatedBytes) return fail(0, "a deflated data set over 1 GiB", false);
            return fail(0, "a deflated data set that does not inflate", zr == Z_BUF_ERROR || zr == Z_OK);
        }
        out.resize(produced);
        inflated_.swap(out);
        data_ = inflated_.data();
        size_t pos = 0;
        return dataset(pos, inflated_.size(), 0, false);
    }
};

/* Reads a whole file into memory (at most kMaxFileBytes); of a file without the DICM
   magic only its first 132 bytes, which is enough for the walk to refuse it (a folder
   may hold large files of other kinds). */
picvr_io_status read_file(const char *path, std::vector<char> &out, std::string &why) {
    FILE *f = fopen(path, "rb");
    if (!f) return why = strerror(errno), PICVR_IO_ERROR_OPEN;
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size < 0) {
        fclose(f);
        return why = "not a regular file", PICVR_IO_ERROR_OPEN;
    }
    const uintmax_t size = (uintmax_t)st.st_size;
    out.resize(size < 132 ? (size_t)size : 132);
    size_t got = out.empty() ? 0 : fread(out.data(), 1, out.size(), f);
    if (got == 132 && memcmp(out.data() + 128, "DICM", 4) == 0 && size > 132) {
        if (size > kMaxFileBytes) {
            fclose(f);
            return why = "over 4 GiB: not one DICOM slice", PICVR_IO_ERROR_BAD_HEADER;
        }
        out.resize((size_t)size);
        got += fread(out.data() + 132, 1, out.size() - 132, f);
    }
    const bool bad = ferror(f) != 0;
    fclose(f);
    if (bad) return why = "read error", PICVR_IO_ERROR_READ;
    out.resize(got);   /* a file that shrank meanwhile: what was there */
    return PICVR_IO_OK;
}

/* An input stream over bytes in memory, without copying them (GDCM reads it with
   seekg/tellg). */
class MemoryBuf : public std::streambuf {
public:
    MemoryBuf(char *b, size_t n) { setg(b, b, b + n); }

protected:
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode which) override {
        if (!(which & std::ios_base::in)) return pos_type(off_type(-1));
        off_type base = dir == std::ios_base::beg ? 0 : dir == std::ios_base::cur ? gptr() - eback() : egptr() - eback();
        off_type at = base + off;
        if (at < 0 || at > egptr() - eback()) return pos_type(off_type(-1));
        setg(eback(), eback() + at, egptr());
        return pos_type(at);
    }
    pos_type seekpos(pos_type p, std::ios_base::openmode which) override {
        return seekoff(off_type(p), std::ios_base::beg, which);
    }
};

/* Reads the attributes of one file (its header).  Returns 1 for an image, 0 when the
   file is not DICOM (or refused by the walk) or has no Rows/Columns (skipped in a
   folder), -1 for an image with a malformed attribute, -2 when the file cannot be read
   (message in why).  An image whose only fault is pixel data cut short by the end of
   the file is returned (1) with s.truncated set, so that a truncated slice of a series
   is refused rather than silently left out. */
int read_header(const std::string &path, Slice &s, std::string &why) {
    std::vector<char> bytes;
    if (read_file(path.c_str(), bytes, why) != PICVR_IO_OK) return -2;
    Walker walk;
    if (!walk.walk_file(bytes)) {
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
    if (s.photometric != r.photometric) return "PhotometricInterpretation " + quote(s.photometric, 16) + ", not " + quote(r.photometric, 16);
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

/* ---- encapsulated (compressed) pixel data -------------------------------------------
 * Each codec is called directly, not through gdcm::Bitmap::GetBuffer, after the stream's
 * own header (JPEG frame header, JPEG 2000 SIZ, RLE header) has been checked against the
 * DICOM header, because GDCM 3.0.21 trusts one where it should check the other:
 *  - GetBuffer falls back, when the IJG codec fails on a JPEG stream, on the PVRG codec,
 *    which Debian's GDCM builds to write the stream to a temporary file and run the
 *    external pvrg-jpeg program on it (system()), leaving the file behind on failure;
 *  - GetBuffer asserts that the codec's output is as long as the DICOM header says
 *    (an abort in Debian's build) before copying it;
 *  - JPEG2000Codec sizes its output from the DICOM header and fills it from the
 *    codestream's size and precision: a heap overflow when they differ;
 *  - JPEG-LS and JPEG allocate what their stream header announces (up to 65535^2
 *    samples from a few bytes);
 *  - RLECodec divides by the header's segment count (0: SIGFPE) and indexes its 15
 *    offsets with it. */

uint32_t be16(const unsigned char *b) { return (uint32_t)b[0] << 8 | b[1]; }
uint32_t be32(const unsigned char *b) { return (uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | b[3]; }

/* The frame header (SOFn, or JPEG-LS SOF55) of a JPEG stream: the first one, before any
   scan, as IJG and CharLS read it. */
bool jpeg_frame(const std::vector<unsigned char> &b, unsigned &precision, unsigned &width, unsigned &height, unsigned &comps) {
    if (b.size() < 4 || b[0] != 0xff || b[1] != 0xd8) return false;
    size_t i = 2;
    while (i + 4 <= b.size()) {
        if (b[i] != 0xff) return false;
        const unsigned m = b[i + 1];
        if (m == 0xff) {   /* fill byte */
            i++;
            continue;
        }
        if (m == 0x01 || (m >= 0xd0 && m <= 0xd7)) {   /* markers without a length */
            i += 2;
            continue;
        }
        const size_t len = be16(&b[i + 2]);
        if (len < 2 || len > b.size() - i - 2) return false;
        const bool sof = (m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc) || m == 0xf7;
        if (sof) {
            if (len < 8) return false;
            precision = b[i + 4];
            height = be16(&b[i + 5]);
            width = be16(&b[i + 7]);
            comps = b[i + 9];
            return true;
        }
        if (m == 0xda || m == 0xd9) return false;   /* a scan or the end before the frame header */
        i += 2 + len;
    }
    return false;
}

/* The image size, component count and first component's precision from a JPEG 2000
   codestream's SIZ marker (right after SOC, as the standard requires). */
bool j2k_size(const std::vector<unsigned char> &b, unsigned &width, unsigned &height, unsigned &comps, unsigned &precision) {
    if (b.size() < 45 || be16(&b[0]) != 0xff4f || be16(&b[2]) != 0xff51) return false;
    const uint32_t lsiz = be16(&b[4]);
    comps = be16(&b[40]);
    if (comps < 1 || lsiz != 38 + 3 * comps || b.size() < 4 + (size_t)lsiz) return false;
    const uint64_t x1 = be32(&b[8]), y1 = be32(&b[12]), x0 = be32(&b[16]), y0 = be32(&b[20]);
    const unsigned ssiz = b[42], dx = b[43], dy = b[44];
    if (dx == 0 || dy == 0 || x0 >= x1 || y0 >= y1) return false;
    /* openjpeg's component size: ceil(x1 / dx) - ceil(x0 / dx) */
    const uint64_t w = (x1 + dx - 1) / dx - (x0 + dx - 1) / dx, h = (y1 + dy - 1) / dy - (y0 + dy - 1) / dy;
    if (w > 0xffffffffu || h > 0xffffffffu) return false;
    width = (unsigned)w;
    height = (unsigned)h;
    precision = (ssiz & 0x7f) + 1;
    return true;
}

/* The concatenated fragments of one frame, as the codecs see them. */
std::vector<unsigned char> fragments_bytes(const gdcm::SequenceOfFragments &sf) {
    std::vector<unsigned char> b;
    for (size_t i = 0; i < sf.GetNumberOfFragments(); i++) {
        const gdcm::ByteValue *bv = sf.GetFragment(i).GetByteValue();
        if (bv && bv->GetPointer()) b.insert(b.end(), bv->GetPointer(), bv->GetPointer() + bv->GetLength());
    }
    return b;
}

picvr_io_status decode_encapsulated(const Slice &s, const gdcm::Image &img, const gdcm::DataElement &pd, unsigned char *dst,
                                    size_t slice_bytes, char *err, size_t err_size) {
    const char *p = s.path.c_str();
    const gdcm::TransferSyntax &ts = img.GetTransferSyntax();
    const char *tsname = gdcm::TransferSyntax::GetTSString(ts);
    const gdcm::SequenceOfFragments *sf = pd.GetSequenceOfFragments();
    if (!sf || sf->GetNumberOfFragments() < 1) FAIL(PICVR_IO_ERROR_TRUNCATED, "%s: no pixel data fragment", p);
    const std::vector<unsigned char> b = fragments_bytes(*sf);
    const unsigned bytes = s.bits / 8;
    gdcm::JPEGCodec jpeg;
    gdcm::JPEGLSCodec jpegls;
    gdcm::JPEG2000Codec j2k;
    gdcm::RLECodec rle;
    gdcm::ImageCodec *codec = nullptr;
    unsigned prec = 0, w = 0, h = 0, nc = 0;
    if (jpeg.CanDecode(ts) || jpegls.CanDecode(ts)) {
        if (!jpeg_frame(b, prec, w, h, nc)) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: a %s stream without a readable frame header", p, tsname);
        const unsigned need = prec <= 8 ? 1 : prec <= 16 ? 2 : 0;
        if (w != s.cols || h != s.rows || nc != 1 || need != bytes)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: the JPEG stream is %ux%u, %u components of %u bits; the header says %ux%u, 1 of %u",
                 p, w, h, nc, prec, s.cols, s.rows, s.bits);
        if (jpegls.CanDecode(ts)) {
            jpegls.SetBufferLength((unsigned long)slice_bytes);
            codec = &jpegls;
        } else {
            codec = &jpeg;
        }
    } else if (j2k.CanDecode(ts)) {
        if (b.size() >= 12 && !memcmp(b.data(), "\x00\x00\x00\x0c\x6a\x50\x20\x20\x0d\x0a\x87\x0a", 12))
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: JPEG 2000 in a JP2 file wrapper (DICOM holds the bare codestream) is not read", p);
        if (!j2k_size(b, w, h, nc, prec)) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: a JPEG 2000 stream without a readable SIZ marker", p);
        const unsigned need = prec <= 8 ? 1 : prec <= 16 ? 2 : prec <= 32 ? 4 : 0;
        if (w != s.cols || h != s.rows || nc != 1 || need != bytes)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: the JPEG 2000 stream is %ux%u, %u components of %u bits; the header says %ux%u, 1 of %u",
                 p, w, h, nc, prec, s.cols, s.rows, s.bits);
        codec = &j2k;
    } else if (rle.CanDecode(ts)) {
        /* one fragment per frame; a segment per byte of the sample, the first at 64 */
        const std::vector<unsigned char> &f = b;
        if (sf->GetNumberOfFragments() != 1 || f.size() < 64) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: RLE pixel data: one fragment of at least 64 bytes", p);
        auto le32 = [&](size_t i) { return (uint32_t)f[i] | (uint32_t)f[i + 1] << 8 | (uint32_t)f[i + 2] << 16 | (uint32_t)f[i + 3] << 24; };
        const uint32_t nseg = le32(0);
        bool ok = nseg == bytes && le32(4) == 64;
        for (uint32_t k = 0; ok && k < nseg; k++) {
            const uint32_t off = le32(4 + 4 * k);
            ok = off >= 64 && off < f.size() && (k == 0 || off > le32(4 * k));
        }
        if (!ok) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: an RLE header that does not fit a %u-bit grey image", p, s.bits);
        rle.SetBufferLength((unsigned long)slice_bytes);
        codec = &rle;
    } else {
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: transfer syntax %s is not read (JPEG, JPEG-LS, JPEG 2000 and RLE are)", p, tsname);
    }
    const unsigned int dims[3] = {s.cols, s.rows, 1};
    codec->SetNumberOfDimensions(2);
    codec->SetDimensions(dims);
    codec->SetPlanarConfiguration(0);
    codec->SetPhotometricInterpretation(img.GetPhotometricInterpretation());
    codec->SetPixelFormat(img.GetPixelFormat());
    codec->SetNeedOverlayCleanup(s.bits_stored != s.bits);
    gdcm::DataElement out;
    if (!codec->Decode(pd, out)) FAIL(PICVR_IO_ERROR_READ, "%s: GDCM cannot decode the pixel data (transfer syntax %s)", p, tsname);
    const gdcm::PixelFormat &cpf = codec->GetPixelFormat();
    if (cpf.GetBitsAllocated() != s.bits || cpf.GetSamplesPerPixel() != 1)
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: the stream decodes to %u samples of %u bits, the header says 1 of %u", p,
             (unsigned)cpf.GetSamplesPerPixel(), (unsigned)cpf.GetBitsAllocated(), s.bits);
    const gdcm::ByteValue *obv = out.GetByteValue();
    if (!obv || !obv->GetPointer() || obv->GetLength() < slice_bytes)
        FAIL(PICVR_IO_ERROR_READ, "%s: the stream decodes to fewer bytes than the slice needs", p);
    memcpy(dst, obv->GetPointer(), slice_bytes);
    return PICVR_IO_OK;
}

/* Decodes one slice into dst (slice_bytes bytes).  The file is read with gdcm::Reader
   and the image built here from the attributes this reader parsed and checked, then
   decoded by GDCM's codecs (above; native data through gdcm::Bitmap::GetBuffer, which
   copies it): gdcm::ImageReader is not used
   because its geometry helpers (gdcm::ImageHelper) assert on malformed attributes
   (e.g. a Frame Increment Pointer without Number of Frames aborts the process in
   Debian's build, whose assertions are on), and this reader needs none of them. */
picvr_io_status decode_slice(const Slice &s, unsigned char *dst, size_t slice_bytes, char *err, size_t err_size) {
    const char *p = s.path.c_str();
    std::vector<char> bytes;
    std::string why;
    picvr_io_status st = read_file(p, bytes, why);
    if (st != PICVR_IO_OK) FAIL(st, "%s: %s", p, why.c_str());
    Walker walk;
    if (!walk.walk_file(bytes)) FAIL(walk.truncated ? PICVR_IO_ERROR_TRUNCATED : PICVR_IO_ERROR_BAD_HEADER, "%s: %s", p, walk.error.c_str());
    MemoryBuf buf(bytes.data(), bytes.size());
    std::istream in(&buf);
    gdcm::Reader r;
    r.SetStream(in);
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
    if (!ts.IsEncapsulated()) {
        if (!img.GetBuffer(reinterpret_cast<char *>(dst)))
            FAIL(PICVR_IO_ERROR_READ, "%s: GDCM cannot copy the pixel data (transfer syntax %s)", p, gdcm::TransferSyntax::GetTSString(ts));
    } else {
        st = decode_encapsulated(s, img, pd, dst, slice_bytes, err, err_size);
        if (st != PICVR_IO_OK) return st;
    }
    if (s.bits == 32 && ts == gdcm::TransferSyntax::ExplicitVRBigEndian) {
        /* GDCM byte-swaps big-endian OW data as 16-bit words on reading: the two halves
           of each 32-bit value are still in big-endian order. */
        for (size_t i = 0; i + 4 <= slice_bytes; i += 4) {
            uint16_t h[2];
            memcpy(h, dst + i, 4);
            std::swap(h[0], h[1]);
            memcpy(dst + i, h, 4);
        }
    }
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
        if (r == -2) FAIL(PICVR_IO_ERROR_OPEN, "%s: %s", path, why.c_str());
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
        if (r == 0 || r == -2) {
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
                 quote(chosen->first, 64).c_str(), slices.size(), series.size() - 1);
        warnings.push_back(buf);
    }
    if (folder && skipped) warnings.push_back(std::to_string(skipped) + " files skipped: not DICOM images, or unreadable");

    /* ---- checks: one layout for all slices ---- */
    const Slice &ref = slices[0];
    for (const Slice &s : slices) {
        const char *p = s.path.c_str();
        if (!s.bad.empty()) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: %s", p, s.bad.c_str());
        if (!s.truncated.empty()) FAIL(PICVR_IO_ERROR_TRUNCATED, "%s: truncated: %s", p, s.truncated.c_str());
        if (s.frames > 1) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: a multi-frame image (%ld frames) is not read: one frame per file", p, s.frames);
        if (s.samples != 1) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: SamplesPerPixel %u: only grey images (1) are read", p, s.samples);
        if (s.photometric != "MONOCHROME1" && s.photometric != "MONOCHROME2")
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: PhotometricInterpretation '%s': only MONOCHROME1/2 are read", p, quote(s.photometric, 32).c_str());
        if (s.bits != 8 && s.bits != 16 && s.bits != 32)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: BitsAllocated %u: 8, 16 or 32 are read", p, s.bits);
        /* HighBit = BitsStored - 1, as the image IODs require: GDCM asserts (aborts) on a
           HighBit at or above BitsStored */
        if (s.bits_stored < 1 || s.bits_stored > s.bits || s.high_bit + 1 != s.bits_stored)
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
    if ((uint64_t)bytes > (uint64_t)(PICVR_IO_DICOM_MAX_BYTES))
        FAIL(PICVR_IO_ERROR_SIZE_OVERFLOW, "%s: %ux%ux%zu voxels need %zu bytes, more than this reader's limit of %llu", path,
             ref.cols, ref.rows, nz, bytes, (unsigned long long)(PICVR_IO_DICOM_MAX_BYTES));
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
    volume->patient_frame = 1;   /* DICOM's patient coordinates are LPS */
    volume->has_origin = 1;
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
