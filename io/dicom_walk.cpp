/* dicom_walk.cpp - the structure check of the DICOM reader (io/dicom.h): each file is
 * read into memory (read_file) and walked here (walk_file) before GDCM reads the same
 * bytes, because GDCM trusts the lengths a file announces.
 *
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
#include "io/dicom.h"

#ifndef PICVR_IO_NO_DICOM

#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>

#include <zlib.h>

#include <gdcmSwapCode.h>
#include <gdcmTransferSyntax.h>

namespace picvr_io_dicom {
namespace {

const int kMaxDepth = 16;
const size_t kMaxFileBytes = (size_t)1 << 32;        /* one slice file at most (4 GiB) */
const size_t kMaxInflatedBytes = (size_t)1 << 30;    /* a deflated data set, inflated */

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

} // namespace

bool walk_file(const std::vector<char> &file, WalkResult &result) {
    Walker walk;
    const bool ok = walk.walk_file(file);
    result.error = walk.error;
    result.truncated = walk.truncated;
    result.pixel_truncated = walk.pixel_truncated;
    return ok;
}

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

} // namespace picvr_io_dicom

#endif /* PICVR_IO_NO_DICOM */
