// one_file_test.cpp - the one-file form in C++17 (tools/check_build.sh): the whole library
// compiles inside this file, and a small scene renders through it.  Checked: every call
// returns PICVR_OK, the image is finite, a lit ball in front of a black background is
// brighter at its centre than at a corner, and the validation layer reports nothing.
#include <cmath>
#include <cstdio>
#include <vector>

#define PICVR_IMPLEMENTATION
#include "picvr.h"

static bool ok(picvr_status s, const char *what) {
    if (s != PICVR_OK) std::fprintf(stderr, "one_file_test: %s: %s\n", what, picvr_status_string(s));
    return s == PICVR_OK;
}

int main() {
    picvr_config cfg = {};   // C++: {} zeroes without -Wmissing-field-initializers
    picvr_context *ctx = nullptr;
    if (!ok(picvr_create(&cfg, &ctx), "picvr_create")) return 1;
    const uint32_t n = 32;
    std::vector<uint8_t> voxels(n * n * n);
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t y = 0; y < n; y++)
            for (uint32_t x = 0; x < n; x++) {
                double dx = x - 15.5, dy = y - 15.5, dz = z - 15.5;
                voxels[x + n * (y + n * z)] = std::sqrt(dx * dx + dy * dy + dz * dz) < 12.0 ? 255 : 0;
            }
    picvr_volume_desc vol = {};
    vol.dims[0] = vol.dims[1] = vol.dims[2] = n;
    vol.type = PICVR_VOXEL_UINT8;
    vol.data = voxels.data();
    picvr_light sun = {};
    sun.type = PICVR_LIGHT_DIRECTIONAL;
    sun.direction[2] = 1;
    sun.color[0] = sun.color[1] = sun.color[2] = 1;
    sun.intensity = 2;
    picvr_camera cam = {};
    cam.position[2] = 80;
    cam.width = cam.height = 32;
    bool good = ok(picvr_upload_volume(ctx, &vol), "picvr_upload_volume") &&
                ok(picvr_set_lights(ctx, &sun, 1, nullptr), "picvr_set_lights") &&
                ok(picvr_set_camera(ctx, &cam), "picvr_set_camera") &&
                ok(picvr_step_iterations(ctx, 8), "picvr_step_iterations");
    std::vector<float> img(32 * 32 * 4);
    picvr_stats st = {};
    good = good && ok(picvr_read_rgba32f(ctx, img.data(), img.size() * sizeof(float)), "picvr_read_rgba32f") &&
           ok(picvr_get_stats(ctx, &st), "picvr_get_stats");
    picvr_destroy(ctx);
    if (!good) return 1;
    for (float v : img)
        if (!std::isfinite(v)) { std::fprintf(stderr, "one_file_test: a non-finite pixel\n"); return 1; }
    float centre = img[(16 * 32 + 16) * 4 + 1], corner = img[1];
    std::printf("one_file_test: %u iterations, centre %.4f, corner %.4f, %u validation messages\n",
                st.iterations, centre, corner, st.validation_messages);
    return st.iterations == 8 && centre > 0.01f && corner == 0.0f && st.validation_messages == 0 ? 0 : 1;
}
