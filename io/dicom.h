/* dicom.h - what the files of the DICOM reader share (private, C++, namespace
 * picvr_io_dicom): one slice file's attributes (Slice), a folder's chosen series (Series)
 * and where its slices lie (Placement), and the functions of
 *   io/dicom_walk.cpp    a file read into memory and its structure checked before GDCM
 *                        reads it (read_file, walk_file, MemoryBuf);
 *   io/dicom_slice.cpp   one file's header: its attributes parsed from their bytes
 *                        (read_header);
 *   io/dicom_pixels.cpp  one slice's pixels decoded by GDCM's codecs (decode_slice);
 *   io/dicom_series.cpp  the series gathered from the folder, checked and placed;
 *   io/dicom.cpp         the load (picvr_io_load_dicom) that calls them in turn.
 * A build without GDCM (PICVR_IO_NO_DICOM) compiles none of it: io/dicom.cpp then says so. */
#ifndef PICVR_IO_DICOM_H
#define PICVR_IO_DICOM_H

#ifndef PICVR_IO_NO_DICOM

#include <cstddef>
#include <ios>
#include <streambuf>
#include <string>
#include <vector>

#include "picvr_io.h"
#include "io/internal.h"

/* A message with the file's path in front, into err. */
#define FAIL(status, ...)                                    \
    do {                                                     \
        picvr_io_set_error(err, err_size, __VA_ARGS__);      \
        return (status);                                     \
    } while (0)

namespace picvr_io_dicom {

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

/* The series read from a folder: its slices (in file name order until place_slices sorts
   them by position) and what was noticed and accepted on the way (volume->warning). */
struct Series {
    std::string dir;                    /* the folder */
    std::vector<Slice> slices;          /* at least one */
    std::vector<std::string> warnings;
};

/* Where the slices lie in the patient's LPS frame. */
struct Placement {
    double row[3], col[3];              /* unit vectors along a row and a column */
    double axis_z[3];                   /* the slices' normal; with a gantry tilt, from the
                                           first slice toward the last (unit) */
    double slice_spacing;               /* mm along axis_z from one slice to the next */
};

/* ---- io/dicom_walk.cpp ---- */

/* What the structure check of a file found (walk_file). */
struct WalkResult {
    std::string error;                  /* why the walk failed */
    bool truncated = false;             /* it failed because the bytes ran out */
    bool pixel_truncated = false;       /* ... inside the top-level Pixel Data, all else complete */
};

/* Reads a whole file into memory (at most 4 GiB); of a file without the DICM magic only
   its first 132 bytes, which is enough for walk_file to refuse it (a folder may hold
   large files of other kinds).  OPEN, BAD_HEADER or READ with the reason in why. */
picvr_io_status read_file(const char *path, std::vector<char> &out, std::string &why);

/* Walks every byte of file that GDCM will read: true when GDCM may read it, else false
   with result filled. */
bool walk_file(const std::vector<char> &file, WalkResult &result);

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

/* ---- io/dicom_slice.cpp ---- */

/* At most n characters of a file's string for a message, non-printable bytes as '?'. */
std::string quote(const std::string &v, size_t n);

/* Reads the attributes of one file (its header).  Returns 1 for an image, 0 when the
   file is not DICOM (or refused by the walk) or has no Rows/Columns (skipped in a
   folder), -1 for an image with a malformed attribute, -2 when the file cannot be read
   (message in why).  An image whose only fault is pixel data cut short by the end of
   the file is returned (1) with s.truncated set, so that a truncated slice of a series
   is refused rather than silently left out. */
int read_header(const std::string &path, Slice &s, std::string &why);

/* ---- io/dicom_pixels.cpp ---- */

/* Decodes the pixels of slice s into dst (slice_bytes bytes, as stored: s.bits each). */
picvr_io_status decode_slice(const Slice &s, unsigned char *dst, size_t slice_bytes, char *err, size_t err_size);

/* Copies n stored values of the given type into floats, rescaled. */
void to_float(const unsigned char *in, float *out, size_t n, unsigned bits, unsigned pixrep, double slope, double intercept);

/* ---- io/dicom_series.cpp ---- */

/* Pass 1: the headers of the folder's files (path a folder, or one file of it: folder
   says which), grouped by SeriesInstanceUID; the series with the most slices (a folder)
   or path's own series (a file) into series. */
picvr_io_status gather_series(const char *path, bool folder, Series &series, char *err, size_t err_size);

/* One layout for all slices (their attributes read, grey, one frame, sizes in range,
   the same rows, columns, bits, spacing, orientation and photometric interpretation),
   and at most PICVR_IO_MAX_DIM of them. */
picvr_io_status check_slices(const Series &series, char *err, size_t err_size);

/* Sorts the slices along their normal and computes where they lie: the axes from the
   first slice by file name, the slice spacing from the positions (the median step; a
   gantry tilt turns axis_z toward the last slice); a duplicate position or slices
   stacked 60 degrees or more off their normal are refused. */
picvr_io_status place_slices(Series &series, Placement &placement, char *err, size_t err_size);

} // namespace picvr_io_dicom

#endif /* PICVR_IO_NO_DICOM */
#endif /* PICVR_IO_DICOM_H */
