/* one_file_test.c - the one-file form in strict ISO C (tools/check_build.sh): the
   application includes a system header first, so the library's clock is what ISO C and
   the platform declare without a feature macro.  A timed step (picvr_step, which reads
   that clock) must render at least one iteration of a small lit ball. */
#include <stdio.h>
#include <string.h>

#define PICVR_IMPLEMENTATION
#include "picvr.h"

int main(void) {
    static uint8_t voxels[16 * 16 * 16];
    picvr_config cfg = {0};
    picvr_context *ctx = NULL;
    picvr_volume_desc vol = {0};
    picvr_camera cam = {0};
    picvr_background sky = {{1, 1, 1}, 1, NULL, 0, 0, 0};
    picvr_stats st;
    memset(voxels, 128, sizeof voxels);
    memset(&st, 0, sizeof st);
    vol.dims[0] = vol.dims[1] = vol.dims[2] = 16;
    vol.type = PICVR_VOXEL_UINT8;
    vol.data = voxels;
    cam.position[2] = 60;
    cam.width = cam.height = 16;
    if (picvr_create(&cfg, &ctx) != PICVR_OK) return 1;
    int ok = picvr_upload_volume(ctx, &vol) == PICVR_OK && picvr_set_lights(ctx, NULL, 0, &sky) == PICVR_OK &&
             picvr_set_camera(ctx, &cam) == PICVR_OK && picvr_step(ctx, 50.0) == PICVR_OK &&
             picvr_get_stats(ctx, &st) == PICVR_OK;
    picvr_destroy(ctx);
    printf("one_file_test (C): %u iterations in %.1f ms, %u validation messages\n", st.iterations, st.elapsed_ms,
           st.validation_messages);
    return ok && st.iterations >= 1 && st.elapsed_ms > 0.0 && st.validation_messages == 0 ? 0 : 1;
}
