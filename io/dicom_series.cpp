/* dicom_series.cpp - a DICOM series for the DICOM reader (io/dicom.h): pass 1 over the
 * folder (every regular file's header read, files that are not DICOM images skipped,
 * the rest grouped by SeriesInstanceUID, the largest series or the given file's chosen:
 * gather_series), the checks that all its slices share one layout (check_slices), and
 * its geometry (place_slices): slices sorted by their position along the slice normal
 * (not by name or InstanceNumber), the slice spacing the median of the position
 * differences (not SliceThickness), uneven spacing and gantry tilt accepted and said in
 * the warnings. */
#include "io/dicom.h"

#ifndef PICVR_IO_NO_DICOM

#include <dirent.h>
#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>

namespace picvr_io_dicom {
namespace {

const double kOrientationTolerance = 1e-4;   /* ImageOrientationPatient, per component */
const double kDuplicateTolerance = 1e-4;     /* mm along the normal: the same position */
const double kTiltToleranceDeg = 0.01;       /* below this, the slices stack along n */

std::string fmt(const char *f, double a, double b = 0) {
    char buf[128];
    snprintf(buf, sizeof buf, f, a, b);
    return buf;
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

/* ---- pass 1 ---- */

/* The folder to read (path itself, or a file's folder) and, for one file, the series it
   belongs to (want_series). */
picvr_io_status locate(const char *path, bool folder, std::string &dir, std::string &want_series, char *err,
                       size_t err_size) {
    if (folder) {
        dir = path;
        while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
        return PICVR_IO_OK;
    }
    const char *slash = strrchr(path, '/');
    dir = slash ? std::string(path, slash == path ? 1 : (size_t)(slash - path)) : std::string(".");
    Slice s;
    std::string why;
    int r = read_header(path, s, why);
    if (r == -2) FAIL(PICVR_IO_ERROR_OPEN, "%s: %s", path, why.c_str());
    if (r <= 0) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: %s", path, why.c_str());
    want_series = s.series;
    return PICVR_IO_OK;
}

/* The images among files by SeriesInstanceUID (of a file's folder only want_series);
   an image with a malformed attribute is kept with the reason in Slice::bad, to be
   refused if its series is read.  skipped: the files that are not DICOM images or
   cannot be read. */
void group_by_series(const std::vector<std::string> &files, bool folder, const std::string &want_series,
                     std::map<std::string, std::vector<Slice>> &series, size_t &skipped) {
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
}

/* ---- checks: one layout for all slices ---- */

/* The first reason why slice s cannot be read with ref, the series' first slice by file
   name: what every slice needs, then what all must share (layout_difference). */
picvr_io_status check_slice(const Slice &ref, const Slice &s, char *err, size_t err_size) {
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
    return PICVR_IO_OK;
}

/* ---- geometry ---- */

/* The unit vectors along a row and a column, from ImageOrientationPatient, and the
   normal n of the slices. */
picvr_io_status slice_axes(const Slice &ref, Placement &placement, double n[3], char *err, size_t err_size) {
    double *row = placement.row, *col = placement.col;
    for (int c = 0; c < 3; c++) {
        row[c] = ref.iop[c];
        col[c] = ref.iop[3 + c];
    }
    if (!normalize(row) || !normalize(col) || std::fabs(dot(row, col)) > 1e-3)
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: ImageOrientationPatient: two orthogonal non-zero cosines are needed", ref.path.c_str());
    n[0] = row[1] * col[2] - row[2] * col[1];
    n[1] = row[2] * col[0] - row[0] * col[2];
    n[2] = row[0] * col[1] - row[1] * col[0];
    normalize(n);
    return PICVR_IO_OK;
}

/* The step from slice to slice of the sorted slices (two at least): the median of the
   position differences along n, uneven steps said in the warnings; with a gantry tilt
   the slices stack along first -> last, not along n, and axis_z follows them. */
picvr_io_status stack_spacing(Series &series, const double n[3], Placement &placement, char *err, size_t err_size) {
    const std::vector<Slice> &slices = series.slices;
    const size_t nz = slices.size();
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
        series.warnings.push_back(fmt("uneven slice spacing (%.4g .. %.4g mm), the median used", sorted.front(), sorted.back()));
    /* Gantry tilt: the slices stack along first -> last, not along n. */
    double t[3];
    for (int c = 0; c < 3; c++) t[c] = slices[nz - 1].ipp[c] - slices[0].ipp[c];
    normalize(t);   /* non-zero: the projections differ */
    double cosang = std::min(1.0, dot(t, n));
    double angle = std::acos(cosang) * 180.0 / 3.14159265358979323846;
    if (angle > kTiltToleranceDeg) {
        if (angle >= 60.0)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: the slices stack %.1f degrees off their normal: not one volume",
                 series.dir.c_str(), angle);
        series.warnings.push_back(fmt("gantry tilt of %.3g degrees: the z axis follows the slice positions, "
                                      "not orthogonal to the slices", angle));
        for (int c = 0; c < 3; c++) placement.axis_z[c] = t[c];
        median /= cosang;   /* the step along t that advances `median` along n */
    }
    placement.slice_spacing = median;
    return PICVR_IO_OK;
}

} // namespace

picvr_io_status gather_series(const char *path, bool folder, Series &out, char *err, size_t err_size) {
    std::string want_series;
    picvr_io_status status = locate(path, folder, out.dir, want_series, err, err_size);
    if (status != PICVR_IO_OK) return status;
    const std::string &dir = out.dir;
    std::vector<std::string> files;
    status = list_folder(dir, files, err, err_size);
    if (status != PICVR_IO_OK) return status;
    if (files.empty()) FAIL(PICVR_IO_ERROR_OPEN, "%s: no file in the folder", dir.c_str());
    std::map<std::string, std::vector<Slice>> series;
    size_t skipped = 0;
    group_by_series(files, folder, want_series, series, skipped);
    if (series.empty()) {
        if (!folder) FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: its folder %s no longer holds its series", path, dir.c_str());
        FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: no DICOM image among its %zu files", dir.c_str(), files.size());
    }
    /* The largest series; on a tie the first UID (std::map order): deterministic. */
    auto chosen = series.begin();
    for (auto it = series.begin(); it != series.end(); ++it)
        if (it->second.size() > chosen->second.size()) chosen = it;
    out.slices = std::move(chosen->second);
    if (folder && series.size() > 1) {
        char buf[200];
        snprintf(buf, sizeof buf, "series %.64s (%zu slices) read, %zu other series in the folder ignored",
                 quote(chosen->first, 64).c_str(), out.slices.size(), series.size() - 1);
        out.warnings.push_back(buf);
    }
    if (folder && skipped) out.warnings.push_back(std::to_string(skipped) + " files skipped: not DICOM images, or unreadable");
    return PICVR_IO_OK;
}

picvr_io_status check_slices(const Series &series, char *err, size_t err_size) {
    const std::vector<Slice> &slices = series.slices;
    for (const Slice &s : slices) {
        const picvr_io_status status = check_slice(slices[0], s, err, err_size);
        if (status != PICVR_IO_OK) return status;
    }
    const size_t nz = slices.size();
    if (nz > PICVR_IO_MAX_DIM) FAIL(PICVR_IO_ERROR_BAD_DIMS, "%s: %zu slices, at most %u are read", series.dir.c_str(), nz, PICVR_IO_MAX_DIM);
    return PICVR_IO_OK;
}

picvr_io_status place_slices(Series &series, Placement &placement, char *err, size_t err_size) {
    std::vector<Slice> &slices = series.slices;
    std::vector<std::string> &warnings = series.warnings;
    const size_t nz = slices.size();
    /* The axes and these warnings from the first slice by file name: all slices agree on
       orientation and spacing (check_slices). */
    const Slice &first = slices[0];
    double n[3];
    picvr_io_status status = slice_axes(first, placement, n, err, err_size);
    if (status != PICVR_IO_OK) return status;
    if (!first.has_iop) warnings.push_back("no ImageOrientationPatient: axial identity assumed");
    if (!first.has_spacing) warnings.push_back("no PixelSpacing: 1 mm assumed");
    for (Slice &s : slices) {
        if (!s.has_ipp && nz > 1)
            FAIL(PICVR_IO_ERROR_BAD_HEADER, "%s: no ImagePositionPatient: slices cannot be ordered", s.path.c_str());
        s.along_n = dot(s.ipp, n);
    }
    if (!first.has_ipp) warnings.push_back("no ImagePositionPatient: origin 0 assumed");
    std::stable_sort(slices.begin(), slices.end(), [](const Slice &a, const Slice &b) { return a.along_n < b.along_n; });
    for (int c = 0; c < 3; c++) placement.axis_z[c] = n[c];
    placement.slice_spacing = 1.0;
    if (nz > 1) return stack_spacing(series, n, placement, err, err_size);
    if (slices[0].thickness > 0) {
        placement.slice_spacing = slices[0].thickness;
        warnings.push_back(fmt("one slice: its SliceThickness %g mm taken as the slice spacing", slices[0].thickness));
    }
    return PICVR_IO_OK;
}

} // namespace picvr_io_dicom

#endif /* PICVR_IO_NO_DICOM */
