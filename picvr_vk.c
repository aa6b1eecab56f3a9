/* picvr_vk.c - the Vulkan implementation of picvr.h.
 *
 * Build it either way:
 *   - on its own: `cc -c picvr_vk.c` beside picvr.h, picvr_shaders.h and host/, and link
 *     the object with -lvulkan -lm;
 *   - inside one file of the application: `#define PICVR_IMPLEMENTATION` before
 *     `#include "picvr.h"` (picvr.h then includes this file).
 * The parts in host/ are included here in dependency order: each uses only the parts
 * above it.  ARCHITECTURE.md maps them to the paper's procedures.  No global state. */

/* A monotonic clock is POSIX: ask for it when this file starts its translation unit
   (nothing included yet).  Inside an application's file the clock falls back to what
   the application's headers declare (host/util.c). */
#if !defined(PICVR_H) && !defined(_POSIX_C_SOURCE) && !defined(_GNU_SOURCE) && !defined(_WIN32)
#define _POSIX_C_SOURCE 200809L
#endif

#include "host/internal.h"

#include "host/util.c"
#include "host/vulkan.c"
#include "host/schedule.c"
#include "host/cache.c"
#include "host/image.c"
#include "host/scattering.c"
#include "host/spirv.c"
#include "host/pipelines.c"
#include "host/aux_kernel.c"
#include "host/reproject.c"
#include "host/camera.c"
#include "host/majorant.c"
#include "host/transfer.c"
#include "host/environment.c"
#include "host/lights.c"
#include "host/clip.c"
#include "host/volume.c"
#include "host/rounds.c"
#include "host/step.c"
#include "host/field.c"
#include "host/readback.c"
#include "host/gpu_image.c"
#include "host/context.c"
