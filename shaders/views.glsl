// views.glsl - the numbers of the debug views (the cached rendering variant with
// USE_DEBUG_VIEW renders them; `make check-layout` compares them with picvr.h), and
// luminance, the one scalar of a colour that the statistics and the error view use.
#ifndef VIEWS_GLSL_ONCE
#define VIEWS_GLSL_ONCE 1

// picvr_debug_view (picvr.h): what the rendering procedure writes.
#define VIEW_IMAGE 0u
#define VIEW_CACHE 1u
#define VIEW_CACHE_ERROR 2u

// Rec. 709 luminance: the scalar of Eq. 5, Eq. 12, the update's conflicts and the
// error view.
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

#endif
