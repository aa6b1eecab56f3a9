/* presets.h - named transfer functions, light set-ups and an orbit camera for picvr.
 *
 * Lights and camera are built from the volume's world box (picvr_volume_box), placed
 * relative to its centre c and radius R (half the box diagonal), so every preset works
 * for any volume size and spacing.  Light intensities are chosen so that a lit medium
 * of albedo 1 has a radiance of roughly 0.3 to 1 (well exposed at exposure 1).
 *
 * Only picvr.h's types are used: no Vulkan; link with -lm.
 */
#ifndef PICVR_PRESETS_H
#define PICVR_PRESETS_H

#include <stddef.h>
#include <stdint.h>

#include "picvr.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PVP_MAX_TF_POINTS 64
#define PVP_MAX_LIGHTS 8

/* Creation's share of device time while the cache fills first (picvr-render --warm,
   picvr-bench-error --bias-warm, as an application might while a scene loads), with
   the update at Table 1's largest share, 0.02: together under picvr's limit of 0.9. */
#define PVP_WARM_CREATE_SHARE 0.85f

/* sun-sky: the sun's elevation (degrees) and the size of its sky map (texels). */
#define PVP_SUN_ELEVATION 35.0f
#define PVP_SKY_WIDTH 256
#define PVP_SKY_HEIGHT 128

/* Default orbit view: a 3/4 view from the front right, a little from above. */
#define PVP_DEFAULT_AZIMUTH 35.0f    /* degrees about +y, from +z toward +x */
#define PVP_DEFAULT_ELEVATION 20.0f  /* degrees above the x-z plane */
#define PVP_DEFAULT_DISTANCE 1.0f    /* 1: the box's bounding sphere just fills the view */
#define PVP_DEFAULT_FOV 40.0f        /* vertical field of view, degrees */

typedef enum pvp_status {
    PVP_OK = 0,
    PVP_ERROR_NULL_POINTER,
    PVP_ERROR_UNKNOWN_NAME,   /* no preset of that name */
    PVP_ERROR_BAD_BOX,        /* box not finite or max < min */
    PVP_ERROR_BAD_ARGUMENT    /* camera parameters out of range */
} pvp_status;

/* What a transfer function's normalized values 0..1 span (its window). */
typedef enum pvp_window_kind {
    PVP_WINDOW_RANGE = 0,     /* the volume's value range (picvr_volume_desc.value_min/max,
                                 --range): the data's own units, whatever they are */
    PVP_WINDOW_VALUE,         /* window[0]..window[1] in the data's physical units (stored *
                                 scale + offset: Hounsfield units for CT) */
    PVP_WINDOW_PERCENTILE     /* the data's window[0] and window[1] quantiles (fractions) */
} pvp_window_kind;

/* A transfer function ready for picvr_set_transfer_function(points, count, density),
   with the scattering it is meant for and the window its values are normalized over. */
typedef struct pvp_tf {
    picvr_tf_point points[PVP_MAX_TF_POINTS];
    uint32_t count;
    float density;            /* D, per world unit */
    uint32_t max_bounces;     /* picvr_scattering.max_bounces the preset is made for: 0
                                 (single scattering) but for cloud */
    pvp_window_kind window_kind;
    float window[2];          /* VALUE: physical values; PERCENTILE: fractions in [0, 1] */
    int needs_hu;             /* made for Hounsfield units (CT): applied to data that are
                                 not, it would show nothing useful */
} pvp_tf;

/* Lights ready for picvr_set_lights(lights, count, &background). */
typedef struct pvp_lights {
    picvr_light lights[PVP_MAX_LIGHTS];
    uint32_t count;
    picvr_background background;  /* all zero: black */
} pvp_lights;

/* A static English name for the status; never NULL. */
const char *pvp_status_string(pvp_status status);

/* Transfer-function presets: ct-bone, ct-soft-tissue, ct-lung, ct-angio (Hounsfield
   units, PVP_WINDOW_VALUE, needs_hu), mr (the data's 1st to 99.5th percentiles),
   ct-bonsai, ct-dense, ct-engine, sim, cloud, cloud-iso, thin, ramp (the volume's range).  cloud: HG g 0.8 per point and unlimited bounces (multiple scattering);
   cloud-iso: the same medium isotropic, for single scattering (the benchmarks' cloud of
   earlier versions, which the irradiance cache can serve). */
pvp_status pvp_tf_preset(const char *name, pvp_tf *tf);

/* Light presets: paper1, paper3, paper4 (the set-ups of the paper's section 8, no
   background), paper1-bg, paper3-bg, paper4-bg (plus a modest background), studio,
   sun, sun-sky, headlight, point.  All are placed in the frame of `camera` (position
   and up; the view direction is toward the box centre), like a light kit that moves
   with the camera, so the visible side is lit from any view.  camera NULL: the default
   orbit view.
   sun-sky: the sun at PVP_SUN_ELEVATION degrees above the world's horizon (the x-z
   plane; +y up), its azimuth over the camera's left shoulder, and a clear sky over a
   grey ground as an environment map (presets.c, "Sun and sky", gives the model).  Its
   background.environment points to a map inside presets.c, built at the first call
   (not thread-safe then) and never changed or freed after: constant for the program's
   life, whatever camera is passed (env_rotation turns it to the sun). */
pvp_status pvp_lights_preset(const char *name, const float box_min[3],
                             const float box_max[3], const picvr_camera *camera,
                             pvp_lights *lights);

/* Reads a transfer-function file into *tf: a text table, '#' to the end of a line a
   comment, blank lines ignored; first any of
       units normalized|value   point values are 0..1 of the volume's range (default) or
                                the data's physical values (Hounsfield units for CT):
                                the window is then the first to the last point's value
       density D                picvr's density factor, per world unit (default 1)
       bounces N|unlimited      scatter events after the first (default 0)
   then 2..PVP_MAX_TF_POINTS lines "value r g b opacity [g]": values non-decreasing,
   albedo in [0, 1], opacity >= 0, g in (-1, 1) (default 0); all finite.  On failure
   err (err_size bytes) says which line and why, and *tf is zeroed.
   PVP_ERROR_BAD_ARGUMENT for a malformed file, PVP_ERROR_UNKNOWN_NAME when it cannot be
   read. */
pvp_status pvp_tf_load(const char *path, pvp_tf *tf, char *err, size_t err_size);

/* Moves tf's points from the window [from_lo, from_hi] onto [to_lo, to_hi] (any one
   unit, from_lo < from_hi, to_lo < to_hi): a point at value v of the first lies at the
   same data value in the second, clamped to [0, 1] (the map is increasing, so the
   points stay sorted).  For an application that uploads a volume once over a wide range
   and switches presets with other windows.  PVP_ERROR_BAD_ARGUMENT for an empty or
   non-finite window. */
pvp_status pvp_tf_rewindow(pvp_tf *tf, double from_lo, double from_hi, double to_lo, double to_hi);

/* Whether a scan is a CT in Hounsfield units: modality "CT" (DICOM's rescale gives HU
   by the standard), or physical values whose 0.5th percentile p005 is air
   (-3100..-800: air is -1000, scanners pad outside the field of view with down to
   -3024) and whose largest, max, is tissue, bone or metal (0..40000: most voxels of a
   scan may be air).  An MR's values are not negative, an MR phase image's reach -4096. */
int pvp_is_hounsfield(const char *modality, double p005, double max);

/* Preset names and one-line descriptions for --help: index 0, 1, ... until NULL. */
const char *pvp_tf_name(size_t index);
const char *pvp_tf_description(size_t index);
const char *pvp_lights_name(size_t index);
const char *pvp_lights_description(size_t index);

/* An orbit camera looking at the box centre from azimuth/elevation (degrees) at
   distance_factor times the distance where the box's bounding sphere just fills the
   field of view (both vertically and horizontally).  fov_y_degrees in (0, 179];
   width and height 1..PICVR_MAX_IMAGE_SIZE; distance_factor > 0.  The up vector
   follows the orbit, so elevations of +-90 degrees work. */
pvp_status pvp_orbit_camera(const float box_min[3], const float box_max[3],
                            float azimuth_degrees, float elevation_degrees,
                            float distance_factor, float fov_y_degrees,
                            uint32_t width, uint32_t height, picvr_camera *camera);

/* The same orbit in another frame: azimuth 0, elevation 0 looks from `front` (a unit
   vector from the box centre toward the eye) with `up` up; azimuth turns about up,
   elevation toward it.  front (0,0,1) and up (0,1,0) are pvp_orbit_camera.  front and
   up must be orthogonal unit vectors (PVP_ERROR_BAD_ARGUMENT). */
pvp_status pvp_orbit_camera_frame(const float box_min[3], const float box_max[3], const float front[3],
                                  const float up[3], float azimuth_degrees, float elevation_degrees,
                                  float distance_factor, float fov_y_degrees, uint32_t width,
                                  uint32_t height, picvr_camera *camera);

/* Views of a scan in the patient's LPS frame (+x left, +y posterior, +z superior):
   anterior, posterior, left, right, superior, inferior; front and up as
   pvp_orbit_camera_frame takes them (superior and inferior: anterior at the top).
   PVP_ERROR_UNKNOWN_NAME for another name. */
pvp_status pvp_patient_view(const char *name, float front[3], float up[3]);

/* The numbers of picvr_cache_config by field name (gamma, epsilon, delta_voxels,
   radius_min_voxels, radius_max_voxels, update_threshold), for --cache-param
   NAME=VALUE of picvr-render and picvr-bench-error: index 0, 1, ... until NULL. */
const char *pvp_cache_param_name(size_t index);

/* The value of the field at that index in c (0: the library's default); 0 past the end. */
float pvp_cache_param_get(const picvr_cache_config *c, size_t index);

/* Sets one field from "NAME=VALUE": PVP_ERROR_UNKNOWN_NAME for another name,
   PVP_ERROR_BAD_ARGUMENT unless VALUE is a positive finite float (c unchanged then).
   The library checks the rest (epsilon < 1, radius_min <= radius_max) at picvr_create:
   PICVR_ERROR_INVALID_ARGUMENT. */
pvp_status pvp_cache_param_set(picvr_cache_config *c, const char *name_value);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_PRESETS_H */
