/* dicom_pixels.cpp - one slice's pixels for the DICOM reader (io/dicom.h): the file read
 * whole and walked again (io/dicom_walk.cpp), read by gdcm::Reader, its image described
 * by the attributes the reader checked (not by gdcm::ImageReader), and decoded: native
 * data through gdcm::Bitmap::GetBuffer, encapsulated data by GDCM's codecs called
 * directly (JPEG, JPEG-LS, JPEG 2000, RLE) after each stream's own header has been
 * checked against the DICOM header (decode_slice); to_float converts stored values. */
#include "io/dicom.h"

#ifndef PICVR_IO_NO_DICOM

#include <string.h>

#include <cstdint>
#include <istream>
#include <utility>

#include <gdcmDataSet.h>
#include <gdcmImage.h>
#include <gdcmJPEG2000Codec.h>
#include <gdcmJPEGCodec.h>
#include <gdcmJPEGLSCodec.h>
#include <gdcmPhotometricInterpretation.h>
#include <gdcmRLECodec.h>
#include <gdcmReader.h>
#include <gdcmSequenceOfFragments.h>
#include <gdcmTag.h>
#include <gdcmTransferSyntax.h>

namespace picvr_io_dicom {

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

namespace {

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

} // namespace

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
    WalkResult walk;
    if (!walk_file(bytes, walk)) FAIL(walk.truncated ? PICVR_IO_ERROR_TRUNCATED : PICVR_IO_ERROR_BAD_HEADER, "%s: %s", p, walk.error.c_str());
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

} // namespace picvr_io_dicom

#endif /* PICVR_IO_NO_DICOM */
