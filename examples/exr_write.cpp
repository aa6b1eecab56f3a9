/* exr_write.cpp - picvr-render's OpenEXR output (--out-float FILE.exr), through the
 * OpenEXR library: RGBA as 32-bit float channels, ZIP-compressed, row 0 the top. */
#include <cstdio>
#include <exception>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>

#include "render.h"

extern "C" int render_write_exr(const char *path, const float *rgba, uint32_t width, uint32_t height,
                                char *err, size_t err_size)
{
    try {
        Imf::Header header((int)width, (int)height);
        header.compression() = Imf::ZIP_COMPRESSION;
        const char *names[4] = {"R", "G", "B", "A"};
        Imf::FrameBuffer fb;
        for (int c = 0; c < 4; c++) {
            header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
            fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char *)(rgba + c), 4 * sizeof(float),
                                           (size_t)width * 4 * sizeof(float)));
        }
        Imf::OutputFile file(path, header);
        file.setFrameBuffer(fb);
        file.writePixels((int)height);
        return 1;
    } catch (const std::exception &e) {
        if (err && err_size) std::snprintf(err, err_size, "%s", e.what());
    } catch (...) {
        if (err && err_size) std::snprintf(err, err_size, "unknown error");
    }
    return 0;
}
