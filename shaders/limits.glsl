// limits.glsl - the loop bounds the kernels share.  llvmpipe silently truncates loops
// past 65535 total iterations per invocation (docs/lavapipe.md), so every tracking loop
// runs at most MAX_TRACK_STEPS iterations; a loop that hits the bound sets `truncated` and
// the sample is counted in the stats.  A render invocation runs at most three tracking
// loops (primary, light sample, phase sample): 3 * 4096 << 65535.  With bounces a path's
// loops draw from one pool of PATH_STEPS instead (tracking.glsl, path_pool).
#ifndef LIMITS_GLSL_ONCE
#define LIMITS_GLSL_ONCE 1
#ifndef MAX_TRACK_STEPS
#define MAX_TRACK_STEPS 4096u   // a kernel may lower it before including this file
#endif
#define PATH_STEPS 49152u   // picvr.h: PICVR_PATH_STEPS

#endif
