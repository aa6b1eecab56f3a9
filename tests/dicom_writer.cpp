/* dicom_writer.cpp - see dicom_writer.h.  Test-only: writes each attribute's bytes
 * itself into a gdcm::DataSet and lets gdcm::Writer add the file meta information.
 * Built with PICVR_IO_NO_DICOM (no GDCM), dw_write_series fails and the tests skip. */
#include "dicom_writer.h"

#include <cstring>

#ifndef PICVR_IO_NO_DICOM

#include <cstdio>
#include <string>
#include <vector>

#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmTransferSyntax.h>
#include <gdcmWriter.h>

namespace {

/* Values are padded to an even length: UI with NUL, other strings with a space. */
void put_string(gdcm::DataSet &ds, uint16_t g, uint16_t e, gdcm::VR vr, std::string v) {
    if (v.size() % 2) v.push_back(vr == gdcm::VR::UI ? '\0' : ' ');
    gdcm::DataElement de(gdcm::Tag(g, e));
    de.SetVR(vr);
    de.SetByteValue(v.data(), (uint32_t)v.size());
    ds.Replace(de);
}

void put_us(gdcm::DataSet &ds, uint16_t g, uint16_t e, uint16_t v) {
    const char b[2] = {(char)(v & 0xff), (char)(v >> 8)};   /* little endian */
    gdcm::DataElement de(gdcm::Tag(g, e));
    de.SetVR(gdcm::VR::US);
    de.SetByteValue(b, 2);
    ds.Replace(de);
}

/* One DS value: at most 16 characters, as precise as fits. */
std::string ds_value(double v) {
    char buf[64];
    for (int prec = 12; prec >= 4; prec--) {
        snprintf(buf, sizeof buf, "%.*g", prec, v);
        if (strlen(buf) <= 16) break;
    }
    return buf;
}

std::string ds_list(const double *v, int n) {
    std::string s;
    for (int i = 0; i < n; i++) {
        if (i) s += '\\';
        s += ds_value(v[i]);
    }
    return s;
}

uint32_t next_rand(uint32_t *state) {   /* xorshift32 */
    uint32_t x = *state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return *state = x;
}

int write_slice(const dw_series *s, uint32_t k, uint32_t file_index) {
    gdcm::Writer w;
    gdcm::File &file = w.GetFile();
    file.GetHeader().SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
    gdcm::DataSet &ds = file.GetDataSet();
    const uint32_t rows = s->rows + ((int)k == s->odd_rows_slice ? 1u : 0u);
    double pos[3];
    for (int c = 0; c < 3; c++)
        pos[c] = s->positions ? s->positions[3 * k + c] : s->ipp0[c] + k * s->step[c];
    const double slope = s->slopes ? s->slopes[k] : s->slope;

    put_string(ds, 0x0008, 0x0016, gdcm::VR::UI, "1.2.840.10008.5.1.4.1.1.2");   /* CT Image Storage */
    put_string(ds, 0x0008, 0x0018, gdcm::VR::UI, std::string(s->series_uid) + "." + std::to_string(k + 1));
    put_string(ds, 0x0008, 0x0060, gdcm::VR::CS, "CT");
    put_string(ds, 0x0010, 0x0010, gdcm::VR::PN, "Phantom^Test");
    put_string(ds, 0x0010, 0x0020, gdcm::VR::LO, "PICVR-TEST");
    if (s->slice_thickness > 0) put_string(ds, 0x0018, 0x0050, gdcm::VR::DS, ds_value(s->slice_thickness));
    put_string(ds, 0x0020, 0x000d, gdcm::VR::UI, "2.25.999");
    put_string(ds, 0x0020, 0x000e, gdcm::VR::UI, s->series_uid);
    /* InstanceNumber runs against the positions: a reader must not sort by it. */
    put_string(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(s->slices - k));
    put_string(ds, 0x0020, 0x0032, gdcm::VR::DS, ds_list(pos, 3));
    put_string(ds, 0x0020, 0x0037, gdcm::VR::DS, ds_list(s->iop, 6));
    put_us(ds, 0x0028, 0x0002, 1);
    put_string(ds, 0x0028, 0x0004, gdcm::VR::CS, s->photometric ? s->photometric : "MONOCHROME2");
    put_us(ds, 0x0028, 0x0010, (uint16_t)rows);
    put_us(ds, 0x0028, 0x0011, (uint16_t)s->cols);
    put_string(ds, 0x0028, 0x0030, gdcm::VR::DS, ds_list(s->pixel_spacing, 2));
    put_us(ds, 0x0028, 0x0100, 16);
    put_us(ds, 0x0028, 0x0101, 16);
    put_us(ds, 0x0028, 0x0102, 15);
    put_us(ds, 0x0028, 0x0103, s->is_signed ? 1 : 0);
    put_string(ds, 0x0028, 0x1052, gdcm::VR::DS, ds_value(s->intercept));
    put_string(ds, 0x0028, 0x1053, gdcm::VR::DS, ds_value(slope));

    std::vector<char> px((size_t)s->cols * rows * 2);
    for (uint32_t y = 0; y < rows; y++)
        for (uint32_t x = 0; x < s->cols; x++) {
            uint16_t v = (uint16_t)dw_value(x, y, k, s->is_signed);
            size_t i = 2 * ((size_t)y * s->cols + x);
            px[i] = (char)(v & 0xff);
            px[i + 1] = (char)(v >> 8);
        }
    gdcm::DataElement pd(gdcm::Tag(0x7fe0, 0x0010));
    pd.SetVR(gdcm::VR::OW);
    pd.SetByteValue(px.data(), (uint32_t)px.size());
    ds.Replace(pd);

    char path[4096];
    snprintf(path, sizeof path, "%s/%s%03u.dcm", s->dir, s->prefix, file_index);
    w.SetFileName(path);
    if (!w.Write()) {
        fprintf(stderr, "dicom_writer: cannot write %s\n", path);
        return -1;
    }
    return 0;
}

} // namespace

extern "C" void dw_defaults(dw_series *s, const char *dir) {
    memset(s, 0, sizeof *s);
    s->dir = dir;
    s->prefix = "s";
    s->series_uid = "2.25.1000";
    s->cols = 8;
    s->rows = 6;
    s->slices = 5;
    s->pixel_spacing[0] = 0.75;
    s->pixel_spacing[1] = 0.5;
    s->slice_thickness = 5.0;
    const double iop[6] = {1, 0, 0, 0, 1, 0};
    memcpy(s->iop, iop, sizeof iop);
    s->ipp0[0] = -10;
    s->ipp0[1] = 20;
    s->ipp0[2] = 30;
    s->step[2] = 2.5;
    s->slope = 1.0;
    s->intercept = -1024.0;
    s->is_signed = 1;
    s->odd_rows_slice = -1;
}

extern "C" int dw_write_series(const dw_series *s, uint32_t *file_of_slice) {
    try {
        std::vector<uint32_t> file(s->slices);
        for (uint32_t k = 0; k < s->slices; k++) file[k] = k;
        uint32_t state = s->shuffle_seed;
        if (state)   /* Fisher-Yates */
            for (uint32_t k = s->slices; k > 1; k--) std::swap(file[k - 1], file[next_rand(&state) % k]);
        for (uint32_t k = 0; k < s->slices; k++) {
            if (write_slice(s, k, file[k])) return -1;
            if (file_of_slice) file_of_slice[k] = file[k];
        }
        return 0;
    } catch (const std::exception &e) {
        fprintf(stderr, "dicom_writer: %s\n", e.what());
        return -1;
    }
}

#else /* PICVR_IO_NO_DICOM */

extern "C" void dw_defaults(dw_series *s, const char *dir) {
    memset(s, 0, sizeof *s);
    s->dir = dir;
}

extern "C" int dw_write_series(const dw_series *, uint32_t *) { return -1; }

#endif /* PICVR_IO_NO_DICOM */
