/* viewer.cpp - picvr-viewer, the interactive viewer and the engine-integration example.
 *
 *   picvr-viewer                        (the Disney cloud under sun and sky)
 *   picvr-viewer --volume ../shared/data/bonsai_256x256x256_uint8.raw.gz --tf ct-bonsai
 *
 * What an engine does with picvr, in one file: the application owns the Vulkan instance,
 * the window's surface (GLFW), the device and its queue, and hands them to picvr
 * (picvr_config.vulkan).  Each frame a step renders for the frame's budget (with
 * scheduler.frames on, a step after a camera change lasts until every pixel holds a
 * sample: no holes; picvr_step_begin/_end, so the window's events keep flowing while
 * the device works), and picvr_write_image writes the image straight into the acquired
 * swapchain image on the device (no host copy), waiting on the acquire semaphore and
 * signalling the one vkQueuePresentKHR waits on.  While the camera is still, the steps
 * keep refining the same image; while it moves, every frame is a fresh real-time one.
 *
 * The library is compiled here (PICVR_IMPLEMENTATION, the one-file form, as C++17); the
 * example helpers (cli, presets, volume_io, env_io) are C objects, linked in.
 *
 * Mouse: left drag orbits about the volume's centre, right drag or the wheel zooms.
 * Keys: T / shift-T transfer-function presets, L / shift-L light presets (placed for the
 * current view), C the irradiance cache on/off (a new context on the same device),
 * V the debug views (with the cache on), R restarts the image, P saves a screenshot,
 * H lists the keys, Esc quits.  The title shows frames per second, samples per pixel
 * and the estimated relative error (picvr_stats.est_rel_error).
 *
 * Tests: --frames N renders N frames and exits; --screenshot FILE.png saves the last
 * frame's swapchain image as shown (tools/check_viewer.sh compares it with
 * picvr-render's image of the same scene).  The Khronos validation layer
 * (PICVR_VALIDATION=1 or --validation) is enabled on the viewer's own instance, whose
 * messenger counts its messages (picvr's own counter only sees instances it makes);
 * with --frames, any message, or a frame with an unsampled pixel, fails the run.
 *
 * Exit status: 0 ok, 1 error (or a failed --frames run), 2 usage error.
 */
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#define PICVR_IMPLEMENTATION
#include "picvr.h"

#include <stb/stb_image_write.h>

#include "cli.h"
#include "env_io.h"
#include "presets.h"
#include "picvr_io.h"

#define PROGRAM "picvr-viewer"
#define EXIT_USAGE 2

/* The scene without options: the README's cloud (picvr-render with these options
   renders the same image). */
#define DEFAULT_VOLUME "../shared/data/wdas_cloud_sixteenth_126x86x154_float32.raw.gz"
static const float DEFAULT_SPACING = 3.33f;
#define DEFAULT_TF "cloud"
#define DEFAULT_LIGHTS "sun-sky"
static const float DEFAULT_CAMERA[3] = {35.0f, -8.0f, 0.75f};

/* ---- options ------------------------------------------------------------------------- */

struct viewer_options {
    const char *volume_path = nullptr;       /* nullptr: DEFAULT_VOLUME and its scene */
    bool have_dims = false, have_type = false, have_spacing = false, have_range = false;
    bool have_density = false, have_bounces = false, have_g = false, have_camera = false;
    bool have_env_rotate = false, have_env_intensity = false, have_size = false;
    uint32_t dims[3] = {0, 0, 0};
    picvr_voxel_type type = PICVR_VOXEL_UINT8;
    float spacing[3] = {1, 1, 1};
    float range[2] = {0, 0};
    const char *tf_name = nullptr, *lights_name = nullptr;  /* nullptr: by the volume */
    float density = 0, g = 0;
    uint32_t bounces = 0;
    float phase_back[2] = {0, 0};
    const char *env_path = nullptr;
    float env_rotate = 0, env_intensity = 1;
    float azimuth = PVP_DEFAULT_AZIMUTH, elevation = PVP_DEFAULT_ELEVATION;
    float distance = PVP_DEFAULT_DISTANCE, fov = PVP_DEFAULT_FOV;
    float exposure = 1;
    uint32_t width = 0, height = 0;          /* 0: by the device (512x384 on a CPU) */
    double frame_ms = 16.0;
    float orbit = 0;                         /* degrees of azimuth per frame (a turntable) */
    uint32_t frames = 0;                     /* 0: interactive */
    const char *screenshot = nullptr;
    uint32_t seed = 0;
    picvr_cache_mode cache = PICVR_CACHE_NONE;
    picvr_switch priorities = PICVR_SWITCH_DEFAULT;
    picvr_switch reuse = PICVR_SWITCH_ON;   /* a moving camera keeps its samples */
    picvr_render_mode render = PICVR_RENDER_MC; /* --render: mc, field, field-mc */
    const char *device = nullptr;
    bool validation = false;
    double max_spp = 65536.0;                /* refinement stops (idles) past this */
};

static void print_help(FILE *f)
{
    fprintf(f,
        "usage: " PROGRAM " [options]\n"
        "Interactive progressive Monte-Carlo volume rendering with picvr: the window's\n"
        "swapchain images are written by picvr on the device (picvr_write_image).\n"
        "Without --volume: the cloud, as picvr-render --volume " DEFAULT_VOLUME "\n"
        "  --spacing 3.33,3.33,3.33 --tf cloud --lights sun-sky --camera 35,-8,0.75.\n"
        "With --volume, what is not given takes picvr-render's defaults, so the same\n"
        "options give the same scene in both programs.\n\n"
        "scene (as picvr-render's)\n"
        "  --volume FILE          raw volume NAME_XxYxZ_TYPE.raw[.gz]\n"
        "  --dims X,Y,Z  --type TYPE  --spacing X,Y,Z  --range MIN,MAX   as picvr-render's\n"
        "  --tf PRESET            transfer function (default from the file, as picvr-render\n"
        "                         chooses it; T cycles the presets, each over its window)\n"
        "  --density D            override the presets' density factor\n"
        "  --lights PRESET        light set-up (default studio; sun-sky for the cloud)\n"
        "  --env FILE.hdr  --env-rotate DEG  --env-intensity X   an environment map\n"
        "  --bounces N|unlimited  --g G  --phase-back G,W   scattering (default: the preset's)\n"
        "  --camera AZ,EL,DIST    orbit camera: degrees, degrees, distance factor\n"
        "                         (default %g,%g,%g; 35,-8,0.75 for the cloud)\n"
        "  --fov DEG              vertical field of view (default %g)\n"
        "  --exposure E           tone-mapping exposure (default 1)\n"
        "  --seed N               random seed (default 0)\n"
        "  --cache off|object|screen|auto  the irradiance cache at start (default off; key C)\n"
        "  --priorities on|off    Eq. 12 block priorities once a frame's pass is done\n"
        "                         (default on; off: round robin, every pixel alike)\n"
        "  --reuse on|off         temporal reuse: a moved camera keeps its samples,\n"
        "                         reprojected (default on)\n"
        "  --render mc|field|field-mc  Monte Carlo (default); the light field alone; or the\n"
        "                         field while anything moves and Monte Carlo from it while\n"
        "                         all is still (docs/field.md; C then does nothing)\n"
        "viewer\n"
        "  --size WxH             window and image size (default 1280x720 on a GPU,\n"
        "                         512x384 on a CPU device)\n"
        "  --frame-ms MS          time budget of a frame (default 16)\n"
        "  --orbit DEG            turn the camera's azimuth by DEG every frame, a turntable\n"
        "                         (default 0; as picvr-render --frames N --orbit DEG)\n"
        "  --max-spp N            stop refining (idle) at N samples per pixel (default 65536)\n"
        "  --device NAME          Vulkan device whose name contains NAME (or PICVR_DEVICE)\n"
        "  --validation           the Khronos validation layer (or PICVR_VALIDATION=1)\n"
        "tests\n"
        "  --frames N             render exactly N frames, print the statistics, exit\n"
        "                         (status 1 if a frame had an unsampled pixel or the\n"
        "                         validation layer said anything)\n"
        "  --screenshot FILE.png  after the last frame, save its swapchain image (also the\n"
        "                         file of key P)\n"
        "keys: left drag orbit, right drag / wheel zoom, T transfer function, L lights,\n"
        "C cache on/off, V debug view (cache on), R restart, P screenshot, H help, Esc quit\n",
        PVP_DEFAULT_AZIMUTH, PVP_DEFAULT_ELEVATION, PVP_DEFAULT_DISTANCE, PVP_DEFAULT_FOV);
    fprintf(f, "\ntransfer functions:");
    for (size_t i = 0; pvp_tf_name(i); i++) fprintf(f, " %s", pvp_tf_name(i));
    fprintf(f, "\nlights:");
    for (size_t i = 0; pvp_lights_name(i); i++) fprintf(f, " %s", pvp_lights_name(i));
    fprintf(f, "\n");
}

static const pvc_option OPTIONS[] = {
    {"help", 0}, {"validation", 0},
    {"volume", 1}, {"dims", 1}, {"type", 1}, {"spacing", 1}, {"range", 1}, {"tf", 1},
    {"density", 1}, {"lights", 1}, {"env", 1}, {"env-rotate", 1}, {"env-intensity", 1},
    {"bounces", 1}, {"g", 1}, {"phase-back", 1}, {"camera", 1}, {"fov", 1}, {"exposure", 1},
    {"seed", 1}, {"cache", 1}, {"priorities", 1}, {"reuse", 1}, {"render", 1}, {"size", 1}, {"frame-ms", 1}, {"orbit", 1}, {"max-spp", 1}, {"device", 1},
    {"frames", 1}, {"screenshot", 1}, {nullptr, 0}};

static bool known_name(const char *value, const char *(*name)(size_t))
{
    for (size_t i = 0; name(i); i++)
        if (!strcmp(value, name(i))) return true;
    return false;
}

static int positive_all(const float *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!(v[i] > 0.0f)) return 0;
    return 1;
}

/* Scene options: the values picvr-render accepts. 1 applied, 0 bad value, -1 not one. */
static int apply_scene_option(void *target, const char *name, const char *value)
{
    viewer_options *o = static_cast<viewer_options *>(target);
    if (!strcmp(name, "volume")) return o->volume_path = value, 1;
    if (!strcmp(name, "dims")) return o->have_dims = pvc_parse_u32s(value, 3, 1, PICVR_IO_MAX_DIM, o->dims);
    if (!strcmp(name, "type")) return o->have_type = picvr_io_parse_type(value, &o->type) == PICVR_IO_OK;
    if (!strcmp(name, "spacing"))
        return o->have_spacing = pvc_parse_floats(value, 3, o->spacing) && positive_all(o->spacing, 3);
    if (!strcmp(name, "range"))
        return o->have_range = pvc_parse_floats(value, 2, o->range) && o->range[0] < o->range[1];
    if (!strcmp(name, "tf")) return o->tf_name = value, known_name(value, pvp_tf_name);
    if (!strcmp(name, "lights")) return o->lights_name = value, known_name(value, pvp_lights_name);
    if (!strcmp(name, "density"))
        return o->have_density = pvc_parse_float(value, &o->density) && o->density >= 0.0f;
    if (!strcmp(name, "env")) return o->env_path = value, 1;
    if (!strcmp(name, "env-rotate")) return o->have_env_rotate = pvc_parse_float(value, &o->env_rotate);
    if (!strcmp(name, "env-intensity"))
        return o->have_env_intensity = pvc_parse_float(value, &o->env_intensity) && o->env_intensity >= 0.0f;
    if (!strcmp(name, "bounces")) return o->have_bounces = pvc_parse_bounces(value, &o->bounces);
    if (!strcmp(name, "g")) return o->have_g = pvc_parse_float(value, &o->g) && o->g > -1.0f && o->g < 1.0f;
    if (!strcmp(name, "phase-back")) {
        float v[2];
        if (!pvc_parse_floats(value, 2, v) || !(v[0] > -1.0f && v[0] < 1.0f) || !(v[1] >= 0.0f && v[1] < 1.0f))
            return 0;
        o->phase_back[0] = v[0];
        o->phase_back[1] = v[1];
        return 1;
    }
    if (!strcmp(name, "camera")) {
        float c[3];
        if (!pvc_parse_floats(value, 3, c) || !(c[2] > 0.0f)) return 0;
        o->azimuth = c[0];
        o->elevation = c[1];
        o->distance = c[2];
        return o->have_camera = true, 1;
    }
    if (!strcmp(name, "fov")) return pvc_parse_float(value, &o->fov) && o->fov > 0.0f && o->fov <= 179.0f;
    if (!strcmp(name, "exposure")) return pvc_parse_float(value, &o->exposure) && o->exposure > 0.0f;
    if (!strcmp(name, "seed")) return pvc_parse_u32(value, 0, UINT32_MAX, &o->seed);
    if (!strcmp(name, "cache")) return pvc_parse_cache_mode(value, &o->cache);
    if (!strcmp(name, "priorities")) return pvc_parse_switch(value, &o->priorities);
    if (!strcmp(name, "reuse")) return pvc_parse_switch(value, &o->reuse);
    if (!strcmp(name, "render")) return pvc_parse_render_mode(value, &o->render);
    return -1;
}

static int apply_viewer_option(void *target, const char *name, const char *value)
{
    viewer_options *o = static_cast<viewer_options *>(target);
    if (!strcmp(name, "validation")) return o->validation = true, 1;
    if (!strcmp(name, "size"))
        return o->have_size = pvc_parse_size(value, PICVR_MAX_IMAGE_SIZE, &o->width, &o->height);
    if (!strcmp(name, "frame-ms")) return pvc_parse_double(value, &o->frame_ms) && o->frame_ms >= 0.0 && o->frame_ms <= 60000.0;
    if (!strcmp(name, "orbit")) return pvc_parse_float(value, &o->orbit);
    if (!strcmp(name, "max-spp")) return pvc_parse_double(value, &o->max_spp) && o->max_spp >= 1.0;
    if (!strcmp(name, "device")) return o->device = value, 1;
    if (!strcmp(name, "frames")) return pvc_parse_u32(value, 1, UINT32_MAX, &o->frames);
    if (!strcmp(name, "screenshot")) return o->screenshot = value, 1;
    return -1;
}

static int apply_option(void *target, const char *name, const char *value)
{
    static const pvc_group_fn groups[] = {apply_scene_option, apply_viewer_option};
    return pvc_apply_by_group(groups, 2, target, name, value);
}

/* Returns -1 to go on, else the exit status (0 after --help, 2 on a usage error). */
static int parse_options(int argc, char **argv, viewer_options *o)
{
    int status = pvc_parse_options(argc, argv, OPTIONS, apply_option, o, print_help);
    if (status >= 0) return status;
    if ((o->have_env_rotate || o->have_env_intensity) && !o->env_path) {
        pvc_fail("--env-rotate and --env-intensity apply to a map: give --env FILE");
        return EXIT_USAGE;
    }
    if (!o->volume_path) {  /* the cloud: the README's options, unless given */
        o->volume_path = DEFAULT_VOLUME;
        if (!o->have_spacing) o->spacing[0] = o->spacing[1] = o->spacing[2] = DEFAULT_SPACING;
        o->have_spacing = true;
        if (!o->tf_name) o->tf_name = DEFAULT_TF;
        if (!o->lights_name) o->lights_name = DEFAULT_LIGHTS;
        if (!o->have_camera) {
            o->azimuth = DEFAULT_CAMERA[0];
            o->elevation = DEFAULT_CAMERA[1];
            o->distance = DEFAULT_CAMERA[2];
        }
    }
    if (!o->lights_name) o->lights_name = "studio";   /* picvr-render's default; the transfer
                                                        function's comes with the file */
    return -1;
}

/* ---- the viewer's state ---------------------------------------------------------------- */

struct viewer {
    viewer_options opt;
    /* host copies kept for the life of the program: a new context (key C) uploads again */
    picvr_io_volume volume = {};
    float *env_rgb = nullptr;
    uint32_t env_width = 0, env_height = 0;

    GLFWwindow *window = nullptr;
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    uint32_t validation_messages = 0;   /* counted by the messenger */
    bool validation = false;
    VkPhysicalDevice phys = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties props = {};
    uint32_t family = 0;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    VkSurfaceKHR surface = VK_NULL_HANDLE;

    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    VkSurfaceFormatKHR surface_format = {VK_FORMAT_UNDEFINED, VK_COLOR_SPACE_SRGB_NONLINEAR_KHR};
    VkExtent2D extent = {0, 0};
    bool swapchain_readable = false;    /* TRANSFER_SRC: screenshots copy what is shown */
    std::vector<VkImage> images;
    std::vector<VkSemaphore> render_done;  /* per swapchain image: present waits on it */
    VkSemaphore acquired = VK_NULL_HANDLE; /* picvr_write_image waits on it */
    VkSemaphore shot_done = VK_NULL_HANDLE;
    bool swapchain_stale = false;

    /* screenshots: a command buffer of the viewer's and a host-visible buffer */
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;

    picvr_context *ctx = nullptr;
    picvr_cache_mode cache = PICVR_CACHE_NONE;
    picvr_debug_view view = PICVR_VIEW_IMAGE;
    size_t tf_index = 0, lights_index = 0;
    double value_window[2] = {0, 0};    /* the stored values the volume is uploaded over */
    pvp_lights lights = {};             /* built once for the first view, then on key L */
    bool lights_built = false;
    float box_min[3] = {0, 0, 0}, box_max[3] = {0, 0, 0};
    float azimuth = 0, elevation = 0, distance = 1;

    /* input */
    bool dragging_left = false, dragging_right = false;
    double mouse_x = 0, mouse_y = 0;
    bool camera_dirty = false;
    int key_tf = 0, key_lights = 0, key_cache = 0, key_view = 0, key_reset = 0, key_shot = 0;
    bool resized = false, refresh = false;  /* refresh: the window system lost the picture */
    bool idle = false;

    /* frame statistics */
    uint32_t frames_done = 0, holes_frames = 0;
    double other_ms = 0.0;              /* frame time outside picvr_step (a running mean) */
    double frame_ms_sum = 0, frame_ms_max = 0, first_frame_ms = 0, step_ms_sum = 0;
    picvr_stats stats = {};
};

static void log_message(picvr_log_level level, const char *message, void *user)
{
    (void)user;
    fprintf(stderr, PROGRAM ": picvr %s: %s\n", pvc_log_level_name(level), message);
}

static bool vk_ok(VkResult r, const char *what)
{
    if (r == VK_SUCCESS) return true;
    pvc_fail("%s: VkResult %d", what, (int)r);
    return false;
}

/* ---- Vulkan: instance, device ------------------------------------------------------------ */

static VKAPI_ATTR VkBool32 VKAPI_CALL on_validation(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                   VkDebugUtilsMessageTypeFlagsEXT type,
                                                   const VkDebugUtilsMessengerCallbackDataEXT *data, void *user)
{
    (void)type;
    viewer *v = static_cast<viewer *>(user);
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        v->validation_messages++;
        fprintf(stderr, PROGRAM ": validation: %s\n", data && data->pMessage ? data->pMessage : "?");
    }
    return VK_FALSE;
}

/* PICVR_VALIDATION as picvr reads it: 0 always off, 1 on; else --validation. */
static bool want_validation(const viewer_options &o)
{
    const char *env = getenv("PICVR_VALIDATION");
    if (env && env[0] == '0') return false;
    return o.validation || (env && env[0] == '1');
}

static bool has_layer(const char *name)
{
    uint32_t n = 0;
    vkEnumerateInstanceLayerProperties(&n, nullptr);
    std::vector<VkLayerProperties> layers(n);
    vkEnumerateInstanceLayerProperties(&n, layers.data());
    for (const VkLayerProperties &l : layers)
        if (!strcmp(l.layerName, name)) return true;
    return false;
}

static bool create_instance(viewer &v)
{
    uint32_t n = 0;
    const char **glfw_ext = glfwGetRequiredInstanceExtensions(&n);
    if (!glfw_ext) {
        pvc_fail("GLFW finds no Vulkan window-system support (no loader or surface extension)");
        return false;
    }
    std::vector<const char *> ext(glfw_ext, glfw_ext + n);
    const char *layer = "VK_LAYER_KHRONOS_validation";
    v.validation = want_validation(v.opt);
    if (v.validation && !has_layer(layer)) {
        fprintf(stderr, PROGRAM ": validation requested but %s is not installed\n", layer);
        v.validation = false;
    }
    if (v.validation) ext.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);

    VkApplicationInfo app = {};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = PROGRAM;
    app.apiVersion = VK_API_VERSION_1_1;
    /* synchronization validation too, as picvr's own instance has it */
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features = {};
    features.sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT;
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = enables;
    VkInstanceCreateInfo ci = {};
    ci.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    ci.pApplicationInfo = &app;
    ci.enabledExtensionCount = (uint32_t)ext.size();
    ci.ppEnabledExtensionNames = ext.data();
    if (v.validation) {
        ci.enabledLayerCount = 1;
        ci.ppEnabledLayerNames = &layer;
        ci.pNext = &features;
    }
    if (!vk_ok(vkCreateInstance(&ci, nullptr, &v.instance), "vkCreateInstance")) return false;
    if (v.validation) {
        auto create = (PFN_vkCreateDebugUtilsMessengerEXT)vkGetInstanceProcAddr(v.instance, "vkCreateDebugUtilsMessengerEXT");
        VkDebugUtilsMessengerCreateInfoEXT mi = {};
        mi.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
        mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        mi.pfnUserCallback = on_validation;
        mi.pUserData = &v;
        if (!create || !vk_ok(create(v.instance, &mi, nullptr, &v.messenger), "vkCreateDebugUtilsMessengerEXT"))
            return false;
    }
    return true;
}

static bool has_device_extension(VkPhysicalDevice d, const char *name)
{
    uint32_t n = 0;
    vkEnumerateDeviceExtensionProperties(d, nullptr, &n, nullptr);
    std::vector<VkExtensionProperties> e(n);
    vkEnumerateDeviceExtensionProperties(d, nullptr, &n, e.data());
    for (const VkExtensionProperties &x : e)
        if (!strcmp(x.extensionName, name)) return true;
    return false;
}

static int device_rank(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

/* The device picvr would pick (discrete > integrated > virtual > CPU, or by name) among
   those with Vulkan 1.1, VK_KHR_swapchain and a queue family with compute that can
   present to this window system; then the device and its one queue. */
static bool create_device(viewer &v)
{
    const char *want = v.opt.device ? v.opt.device : getenv("PICVR_DEVICE");
    uint32_t n = 0;
    vkEnumeratePhysicalDevices(v.instance, &n, nullptr);
    std::vector<VkPhysicalDevice> devs(n);
    if (n) vkEnumeratePhysicalDevices(v.instance, &n, devs.data());
    int best_rank = -1;
    for (VkPhysicalDevice d : devs) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(d, &p);
        if (p.apiVersion < VK_API_VERSION_1_1 || (want && *want && !strstr(p.deviceName, want))) continue;
        if (!has_device_extension(d, VK_KHR_SWAPCHAIN_EXTENSION_NAME)) continue;
        uint32_t nf = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(d, &nf, nullptr);
        std::vector<VkQueueFamilyProperties> fams(nf);
        vkGetPhysicalDeviceQueueFamilyProperties(d, &nf, fams.data());
        for (uint32_t f = 0; f < nf; f++) {
            if (!(fams[f].queueFlags & VK_QUEUE_COMPUTE_BIT) || !glfwGetPhysicalDevicePresentationSupport(v.instance, d, f))
                continue;
            if (device_rank(p.deviceType) > best_rank) {
                best_rank = device_rank(p.deviceType);
                v.phys = d;
                v.props = p;
                v.family = f;
            }
            break;
        }
    }
    if (!v.phys) {
        pvc_fail("no Vulkan 1.1 device%s%s with a compute queue that can present to this display",
                 want && *want ? " matching " : "", want && *want ? want : "");
        return false;
    }
    float prio = 1.0f;
    VkDeviceQueueCreateInfo qi = {};
    qi.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qi.queueFamilyIndex = v.family;
    qi.queueCount = 1;
    qi.pQueuePriorities = &prio;
    const char *ext = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
    VkDeviceCreateInfo di = {};
    di.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    di.queueCreateInfoCount = 1;
    di.pQueueCreateInfos = &qi;
    di.enabledExtensionCount = 1;
    di.ppEnabledExtensionNames = &ext;
    if (!vk_ok(vkCreateDevice(v.phys, &di, nullptr, &v.device), "vkCreateDevice")) return false;
    vkGetDeviceQueue(v.device, v.family, 0, &v.queue);

    VkCommandPoolCreateInfo pi = {};
    pi.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pi.queueFamilyIndex = v.family;
    VkCommandBufferAllocateInfo ai = {};
    ai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    VkFenceCreateInfo fi = {};
    fi.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkSemaphoreCreateInfo si = {};
    si.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    if (!vk_ok(vkCreateCommandPool(v.device, &pi, nullptr, &v.pool), "vkCreateCommandPool")) return false;
    ai.commandPool = v.pool;
    return vk_ok(vkAllocateCommandBuffers(v.device, &ai, &v.cmd), "vkAllocateCommandBuffers") &&
           vk_ok(vkCreateFence(v.device, &fi, nullptr, &v.fence), "vkCreateFence") &&
           vk_ok(vkCreateSemaphore(v.device, &si, nullptr, &v.acquired), "vkCreateSemaphore") &&
           vk_ok(vkCreateSemaphore(v.device, &si, nullptr, &v.shot_done), "vkCreateSemaphore");
}

/* ---- the swapchain ------------------------------------------------------------------------- */

/* picvr_write_image writes these four 8-bit formats; UNORM first: picvr's bytes are
   already sRGB-encoded, so a UNORM image shows them as they are (an _SRGB one too: the
   bytes are copied, not converted). */
static bool pick_surface_format(viewer &v)
{
    uint32_t n = 0;
    vkGetPhysicalDeviceSurfaceFormatsKHR(v.phys, v.surface, &n, nullptr);
    std::vector<VkSurfaceFormatKHR> formats(n);
    vkGetPhysicalDeviceSurfaceFormatsKHR(v.phys, v.surface, &n, formats.data());
    static const VkFormat preferred[] = {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_B8G8R8A8_SRGB,
                                         VK_FORMAT_R8G8B8A8_SRGB};
    for (VkFormat want : preferred)
        for (const VkSurfaceFormatKHR &f : formats)
            if (f.format == want && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
                v.surface_format = f;
                return true;
            }
    pvc_fail("the surface offers none of B8G8R8A8/R8G8B8A8 UNORM/SRGB, which picvr_write_image writes");
    return false;
}

static void destroy_swapchain_objects(viewer &v)
{
    for (VkSemaphore s : v.render_done) vkDestroySemaphore(v.device, s, nullptr);
    v.render_done.clear();
    v.images.clear();
}

/* (Re)creates the swapchain at the surface's size.  Returns false on an error;
   v.extent is 0x0 while the window is minimized (no swapchain then). */
static bool create_swapchain(viewer &v)
{
    vkDeviceWaitIdle(v.device);  /* the old images may still be presented */
    VkSurfaceCapabilitiesKHR caps;
    if (!vk_ok(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(v.phys, v.surface, &caps), "vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))
        return false;
    VkExtent2D e = caps.currentExtent;
    if (e.width == UINT32_MAX) {  /* the surface takes the swapchain's size: the window's */
        int w, h;
        glfwGetFramebufferSize(v.window, &w, &h);
        e.width = std::min(std::max((uint32_t)w, caps.minImageExtent.width), caps.maxImageExtent.width);
        e.height = std::min(std::max((uint32_t)h, caps.minImageExtent.height), caps.maxImageExtent.height);
    }
    e.width = std::min(e.width, (uint32_t)PICVR_MAX_IMAGE_SIZE);
    e.height = std::min(e.height, (uint32_t)PICVR_MAX_IMAGE_SIZE);
    destroy_swapchain_objects(v);
    if (e.width == 0 || e.height == 0) {  /* minimized */
        vkDestroySwapchainKHR(v.device, v.swapchain, nullptr);
        v.swapchain = VK_NULL_HANDLE;
        v.extent = e;
        return true;
    }
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
        pvc_fail("the swapchain's images cannot be transfer destinations (picvr_write_image copies into them)");
        return false;
    }
    v.swapchain_readable = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;

    /* The frame's pace is picvr_step's budget: no waiting for vertical blank if the
       surface can avoid it (FIFO, always there, is the fallback). */
    uint32_t n = 0;
    vkGetPhysicalDeviceSurfacePresentModesKHR(v.phys, v.surface, &n, nullptr);
    std::vector<VkPresentModeKHR> modes(n);
    vkGetPhysicalDeviceSurfacePresentModesKHR(v.phys, v.surface, &n, modes.data());
    VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;
    for (VkPresentModeKHR want : {VK_PRESENT_MODE_IMMEDIATE_KHR, VK_PRESENT_MODE_MAILBOX_KHR})
        if (std::find(modes.begin(), modes.end(), want) != modes.end()) mode = want;

    /* Opaque if it can be: picvr's alpha is the volume's coverage, 0 where the sky shows. */
    VkCompositeAlphaFlagBitsKHR alpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    for (VkCompositeAlphaFlagBitsKHR a : {VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR, VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR,
                                          VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR, VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR})
        if (caps.supportedCompositeAlpha & a) alpha = a;

    VkSwapchainCreateInfoKHR ci = {};
    ci.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
    ci.surface = v.surface;
    ci.minImageCount = caps.maxImageCount ? std::min(caps.minImageCount + 1, caps.maxImageCount) : caps.minImageCount + 1;
    ci.imageFormat = v.surface_format.format;
    ci.imageColorSpace = v.surface_format.colorSpace;
    ci.imageExtent = e;
    ci.imageArrayLayers = 1;
    ci.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | (v.swapchain_readable ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
    ci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;  /* one queue: picvr's is the viewer's */
    ci.preTransform = (caps.supportedTransforms & VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR) ? VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR
                                                                                         : caps.currentTransform;
    ci.compositeAlpha = alpha;
    ci.presentMode = mode;
    ci.clipped = VK_TRUE;
    ci.oldSwapchain = v.swapchain;
    VkSwapchainKHR sc;
    VkResult r = vkCreateSwapchainKHR(v.device, &ci, nullptr, &sc);
    vkDestroySwapchainKHR(v.device, v.swapchain, nullptr);
    v.swapchain = VK_NULL_HANDLE;
    if (!vk_ok(r, "vkCreateSwapchainKHR")) return false;
    v.swapchain = sc;
    v.extent = e;
    n = 0;
    vkGetSwapchainImagesKHR(v.device, sc, &n, nullptr);
    v.images.resize(n);
    vkGetSwapchainImagesKHR(v.device, sc, &n, v.images.data());
    VkSemaphoreCreateInfo si = {};
    si.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
    v.render_done.assign(n, VK_NULL_HANDLE);
    for (VkSemaphore &s : v.render_done)
        if (!vk_ok(vkCreateSemaphore(v.device, &si, nullptr, &s), "vkCreateSemaphore")) return false;
    v.swapchain_stale = false;
    return true;
}

/* ---- picvr: context and scene ------------------------------------------------------------- */

static bool check(picvr_status s, const char *what) { return pvc_check(s, what) != 0; }

/* The orbit's frame: a scan in the patient's frame is seen from anterior, superior up
   (pvp_patient_view); anything else from +z, +y up. */
static void view_frame(const viewer &v, float front[3], float up[3])
{
    static const float z_front[3] = {0, 0, 1}, y_up[3] = {0, 1, 0};
    if (v.volume.patient_frame && pvp_patient_view("anterior", front, up) == PVP_OK) return;
    memcpy(front, z_front, sizeof z_front);
    memcpy(up, y_up, sizeof y_up);
}

static bool set_camera(viewer &v)
{
    picvr_camera cam;
    float front[3], up[3];
    view_frame(v, front, up);
    pvp_status ps = pvp_orbit_camera_frame(v.box_min, v.box_max, front, up, v.azimuth, v.elevation, v.distance,
                                           v.opt.fov, v.extent.width, v.extent.height, &cam);
    if (ps != PVP_OK) {
        pvc_fail("camera: %s", pvp_status_string(ps));
        return false;
    }
    v.camera_dirty = false;
    return check(picvr_set_camera(v.ctx, &cam), "picvr_set_camera");
}

/* The stored values the volume is uploaded over, once for every preset: --range; the
   type's range for uint8, int8 and uint16 (picvr's default, which the presets of the
   Open SciVis data are made for); else the data's min..max (picvr's default for int32
   and the float types; for int16, a CT's HU windows keep their resolution). */
static void upload_window(viewer &v)
{
    const picvr_voxel_type t = v.volume.type;
    double lo = 0.0, hi = 0.0;
    if (v.opt.have_range) lo = v.opt.range[0], hi = v.opt.range[1];
    else if (t == PICVR_VOXEL_UINT8) hi = 255.0;
    else if (t == PICVR_VOXEL_INT8) lo = -128.0, hi = 127.0;
    else if (t == PICVR_VOXEL_UINT16) hi = 65535.0;
    else if (picvr_io_value_range(&v.volume, &lo, &hi, nullptr) != PICVR_IO_OK || !(hi > lo)) hi = lo + 1.0;
    v.value_window[0] = lo;
    v.value_window[1] = hi;
}

/* The preset's window in stored values (presets.h, pvp_window_kind); false when it has
   none that maps (a rescale slope that is not positive). */
static bool preset_window(const viewer &v, const pvp_tf &tf, double w[2])
{
    const picvr_io_volume &vol = v.volume;
    if (tf.window_kind == PVP_WINDOW_PERCENTILE && !v.opt.have_range)
        return picvr_io_percentile_range(&vol, tf.window[0], tf.window[1], &w[0], &w[1]) == PICVR_IO_OK;
    if (tf.window_kind == PVP_WINDOW_VALUE && !v.opt.have_range) {
        if (!(vol.value_scale > 0.0)) return false;
        w[0] = (tf.window[0] - vol.value_offset) / vol.value_scale;
        w[1] = (tf.window[1] - vol.value_offset) / vol.value_scale;
        return true;
    }
    w[0] = v.value_window[0];
    w[1] = v.value_window[1];
    return true;
}

/* The transfer function of preset tf_index, moved from its window onto the volume's
   (pvp_tf_rewindow; unchanged when they are the same, so that the viewer and
   picvr-render agree bit for bit), with the scattering it is made for (the command
   line's --density, --g and --bounces override every preset alike). */
static bool set_transfer_function(viewer &v)
{
    pvp_tf tf;
    if (pvp_tf_preset(pvp_tf_name(v.tf_index), &tf) != PVP_OK) return false;
    double w[2];
    if (preset_window(v, tf, w) && (w[0] != v.value_window[0] || w[1] != v.value_window[1]))
        pvp_tf_rewindow(&tf, w[0], w[1], v.value_window[0], v.value_window[1]);
    for (uint32_t i = 0; v.opt.have_g && i < tf.count; i++) tf.points[i].g = v.opt.g;
    picvr_scattering sc = {v.opt.have_bounces ? v.opt.bounces : tf.max_bounces, v.opt.phase_back[0], v.opt.phase_back[1]};
    return check(picvr_set_transfer_function(v.ctx, tf.points, tf.count, v.opt.have_density ? v.opt.density : tf.density),
                 "picvr_set_transfer_function") &&
           check(picvr_set_scattering(v.ctx, &sc), "picvr_set_scattering");
}

/* The transfer function when --tf is not given, as picvr-render chooses it: ct-bone for
   a CT in Hounsfield units, mr for another scan, cloud for a .vdb, else ramp. */
static const char *default_tf(const viewer &v)
{
    const picvr_io_volume &vol = v.volume;
    double lo = 0.0, hi = 0.0;
    bool have = picvr_io_percentile_range(&vol, 0.005, 1.0, &lo, &hi) == PICVR_IO_OK;
    double a = lo * vol.value_scale + vol.value_offset, b = hi * vol.value_scale + vol.value_offset;
    if (pvp_is_hounsfield(vol.modality, have ? std::min(a, b) : 0.0, have ? std::max(a, b) : 0.0)) return "ct-bone";
    if (vol.patient_frame || vol.modality[0]) return "mr";
    return picvr_io_is_vdb(v.opt.volume_path) ? "cloud" : "ramp";
}

/* Builds preset lights_index around the current view (presets.h: a light kit placed
   in the camera's frame), so the lights then stay put in the world while the camera
   orbits; --env replaces the background. */
static bool build_lights(viewer &v)
{
    picvr_camera cam;
    float front[3], up[3];
    view_frame(v, front, up);
    if (pvp_orbit_camera_frame(v.box_min, v.box_max, front, up, v.azimuth, v.elevation, v.distance, v.opt.fov,
                               std::max(v.extent.width, 1u), std::max(v.extent.height, 1u), &cam) != PVP_OK)
        return false;
    pvp_status ps = pvp_lights_preset(pvp_lights_name(v.lights_index), v.box_min, v.box_max, &cam, &v.lights);
    if (ps != PVP_OK) {
        pvc_fail("lights %s: %s", pvp_lights_name(v.lights_index), pvp_status_string(ps));
        return false;
    }
    if (v.env_rgb) {
        picvr_background *b = &v.lights.background;
        b->color[0] = b->color[1] = b->color[2] = 1.0f;
        b->intensity = v.opt.env_intensity;
        b->environment = v.env_rgb;
        b->env_width = v.env_width;
        b->env_height = v.env_height;
        b->env_rotation = v.opt.env_rotate * 3.14159265358979f / 180.0f;
    }
    v.lights_built = true;
    return true;
}

static bool set_lights(viewer &v)
{
    return check(picvr_set_lights(v.ctx, v.lights.lights, v.lights.count, &v.lights.background), "picvr_set_lights");
}

/* A context on the viewer's device with the given cache mode, the scene set up. */
static bool create_context(viewer &v, picvr_cache_mode cache)
{
    picvr_config cfg = {};
    cfg.seed = v.opt.seed;
    cfg.log = log_message;
    cfg.vulkan.instance = v.instance;
    cfg.vulkan.physical_device = v.phys;
    cfg.vulkan.device = v.device;
    cfg.vulkan.queue = v.queue;
    cfg.vulkan.queue_family = v.family;
    cfg.cache.mode = cache;
    cfg.scheduler.frames = PICVR_SWITCH_ON;  /* every frame a whole image: no holes */
    cfg.scheduler.priorities = v.opt.priorities;
    cfg.scheduler.temporal_reuse = v.opt.reuse;
    cfg.field.mode = v.opt.render;
    if (!check(picvr_create(&cfg, &v.ctx), "picvr_create")) return false;
    v.cache = cache;
    picvr_volume_desc desc;
    picvr_io_to_desc(&v.volume, &desc);
    upload_window(v);
    desc.value_min = (float)v.value_window[0];
    desc.value_max = (float)v.value_window[1];
    bool ok = check(picvr_upload_volume(v.ctx, &desc), "picvr_upload_volume") &&
              check(picvr_volume_box(v.ctx, v.box_min, v.box_max), "picvr_volume_box") &&
              (v.lights_built || build_lights(v)) && set_camera(v) && set_transfer_function(v) && set_lights(v);
    if (ok && v.view != PICVR_VIEW_IMAGE) ok = check(picvr_set_view(v.ctx, v.view), "picvr_set_view");
    /* the pipelines now, not at the first frame (lavapipe still compiles at first use) */
    return ok && check(picvr_prepare(v.ctx), "picvr_prepare");
}

/* ---- screenshots ------------------------------------------------------------------------- */

static bool find_memory(const viewer &v, uint32_t bits, VkMemoryPropertyFlags want, uint32_t *index)
{
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(v.phys, &mp);
    for (uint32_t i = 0; i < mp.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) {
            *index = i;
            return true;
        }
    return false;
}

/* A buffer or image's memory, allocated and bound. */
static bool allocate(const viewer &v, VkMemoryRequirements req, VkMemoryPropertyFlags want, VkDeviceMemory *mem)
{
    uint32_t type;
    if (!find_memory(v, req.memoryTypeBits, want, &type)) {
        pvc_fail("no memory type for the screenshot");
        return false;
    }
    VkMemoryAllocateInfo ai = {};
    ai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    ai.allocationSize = req.size;
    ai.memoryTypeIndex = type;
    return vk_ok(vkAllocateMemory(v.device, &ai, nullptr, mem), "vkAllocateMemory");
}

static VkImageMemoryBarrier image_barrier(VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src,
                                          VkAccessFlags dst)
{
    VkImageMemoryBarrier b = {};
    b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    b.srcAccessMask = src;
    b.dstAccessMask = dst;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    return b;
}

/* Copies an 8-bit RGBA/BGRA image in `layout` (left in it) to a PNG, RGB: one submission
   that waits on `wait` (if any) at the transfer stage and signals `signal` (if any). */
static bool save_image(viewer &v, VkImage image, VkFormat format, VkImageLayout layout, VkSemaphore wait,
                       VkSemaphore signal, const char *path)
{
    const uint32_t w = v.extent.width, h = v.extent.height;
    const VkDeviceSize size = (VkDeviceSize)w * h * 4;
    VkBuffer buf = VK_NULL_HANDLE;
    VkDeviceMemory mem = VK_NULL_HANDLE;
    VkBufferCreateInfo bi = {};
    bi.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    bi.size = size;
    bi.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    bool ok = vk_ok(vkCreateBuffer(v.device, &bi, nullptr, &buf), "vkCreateBuffer");
    VkMemoryRequirements req = {};
    if (ok) vkGetBufferMemoryRequirements(v.device, buf, &req);
    ok = ok && allocate(v, req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT, &mem) &&
         vk_ok(vkBindBufferMemory(v.device, buf, mem, 0), "vkBindBufferMemory");

    VkCommandBufferBeginInfo begin = {};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ok = ok && vk_ok(vkBeginCommandBuffer(v.cmd, &begin), "vkBeginCommandBuffer");
    if (ok) {
        /* picvr's last barrier made its write visible to later commands on the queue;
           the semaphore wait orders this after it */
        VkImageMemoryBarrier to_src = image_barrier(image, layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                                                    VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_TRANSFER_READ_BIT);
        vkCmdPipelineBarrier(v.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                             nullptr, 1, &to_src);
        VkBufferImageCopy region = {};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {w, h, 1};
        vkCmdCopyImageToBuffer(v.cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buf, 1, &region);
        VkImageMemoryBarrier back = image_barrier(image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, layout,
                                                  VK_ACCESS_TRANSFER_READ_BIT, 0);
        VkBufferMemoryBarrier to_host = {};
        to_host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
        to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        to_host.srcQueueFamilyIndex = to_host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        to_host.buffer = buf;
        to_host.size = VK_WHOLE_SIZE;
        vkCmdPipelineBarrier(v.cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr, 1,
                             &to_host, 1, &back);
        ok = vk_ok(vkEndCommandBuffer(v.cmd), "vkEndCommandBuffer");
    }
    VkPipelineStageFlags stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo si = {};
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.waitSemaphoreCount = wait ? 1 : 0;
    si.pWaitSemaphores = &wait;
    si.pWaitDstStageMask = &stage;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &v.cmd;
    si.signalSemaphoreCount = signal ? 1 : 0;
    si.pSignalSemaphores = &signal;
    ok = ok && vk_ok(vkQueueSubmit(v.queue, 1, &si, v.fence), "vkQueueSubmit") &&
         vk_ok(vkWaitForFences(v.device, 1, &v.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    if (ok) vkResetFences(v.device, 1, &v.fence);
    void *mapped = nullptr;
    ok = ok && vk_ok(vkMapMemory(v.device, mem, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    if (ok) {
        VkMappedMemoryRange range = {};
        range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
        range.memory = mem;
        range.size = VK_WHOLE_SIZE;
        vkInvalidateMappedMemoryRanges(v.device, 1, &range);  /* for non-coherent memory */
        const uint8_t *px = static_cast<const uint8_t *>(mapped);
        bool bgra = format == VK_FORMAT_B8G8R8A8_UNORM || format == VK_FORMAT_B8G8R8A8_SRGB;
        std::vector<uint8_t> rgb((size_t)w * h * 3);
        for (size_t i = 0; i < (size_t)w * h; i++) {  /* alpha (coverage) dropped, as picvr-render does */
            rgb[3 * i + 0] = px[4 * i + (bgra ? 2 : 0)];
            rgb[3 * i + 1] = px[4 * i + 1];
            rgb[3 * i + 2] = px[4 * i + (bgra ? 0 : 2)];
        }
        vkUnmapMemory(v.device, mem);
        if (!stbi_write_png(path, (int)w, (int)h, 3, rgb.data(), (int)w * 3)) {
            pvc_fail("cannot write %s", path);
            ok = false;
        }
    }
    vkDestroyBuffer(v.device, buf, nullptr);
    vkFreeMemory(v.device, mem, nullptr);
    return ok;
}

/* Without TRANSFER_SRC on the swapchain: a second picvr_write_image into an RGBA8 image
   of the viewer's, read back the same way. */
static bool save_own_image(viewer &v, const char *path)
{
    VkImageCreateInfo ci = {};
    ci.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = VK_FORMAT_R8G8B8A8_UNORM;
    ci.extent = {v.extent.width, v.extent.height, 1};
    ci.mipLevels = ci.arrayLayers = 1;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.tiling = VK_IMAGE_TILING_OPTIMAL;
    ci.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory mem = VK_NULL_HANDLE;
    bool ok = vk_ok(vkCreateImage(v.device, &ci, nullptr, &image), "vkCreateImage");
    VkMemoryRequirements req = {};
    if (ok) vkGetImageMemoryRequirements(v.device, image, &req);
    ok = ok && allocate(v, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, &mem) &&
         vk_ok(vkBindImageMemory(v.device, image, mem, 0), "vkBindImageMemory");
    picvr_image_target t = {};
    t.image = image;
    t.width = v.extent.width;
    t.height = v.extent.height;
    t.format = VK_FORMAT_R8G8B8A8_UNORM;
    t.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
    t.new_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    t.exposure = v.opt.exposure;
    ok = ok && check(picvr_write_image(v.ctx, &t), "picvr_write_image") &&
         save_image(v, image, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_NULL_HANDLE,
                    VK_NULL_HANDLE, path);
    vkDestroyImage(v.device, image, nullptr);
    vkFreeMemory(v.device, mem, nullptr);
    return ok;
}

/* ---- input ----------------------------------------------------------------------------------- */

static viewer *of(GLFWwindow *w) { return static_cast<viewer *>(glfwGetWindowUserPointer(w)); }

static void on_key(GLFWwindow *w, int key, int scancode, int action, int mods)
{
    (void)scancode;
    viewer *v = of(w);
    if (action != GLFW_PRESS) return;
    int step = (mods & GLFW_MOD_SHIFT) ? -1 : 1;
    switch (key) {
    case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(w, GLFW_TRUE); break;
    case GLFW_KEY_T: v->key_tf += step; break;
    case GLFW_KEY_L: v->key_lights += step; break;
    case GLFW_KEY_C: v->key_cache++; break;
    case GLFW_KEY_V: v->key_view++; break;
    case GLFW_KEY_R: v->key_reset++; break;
    case GLFW_KEY_P: v->key_shot++; break;
    case GLFW_KEY_H:
        printf("keys: left drag orbit, right drag / wheel zoom, T / shift-T transfer function, L / shift-L lights,\n"
               "C cache on/off, V debug view (cache on), R restart the image, P screenshot, Esc quit\n");
        break;
    default: break;
    }
}

static void on_button(GLFWwindow *w, int button, int action, int mods)
{
    (void)mods;
    viewer *v = of(w);
    glfwGetCursorPos(w, &v->mouse_x, &v->mouse_y);
    if (button == GLFW_MOUSE_BUTTON_LEFT) v->dragging_left = action == GLFW_PRESS;
    if (button == GLFW_MOUSE_BUTTON_RIGHT) v->dragging_right = action == GLFW_PRESS;
}

static void on_cursor(GLFWwindow *w, double x, double y)
{
    viewer *v = of(w);
    double dx = x - v->mouse_x, dy = y - v->mouse_y;
    v->mouse_x = x;
    v->mouse_y = y;
    if (v->dragging_left && (dx != 0 || dy != 0)) {  /* the volume follows the mouse */
        v->azimuth = std::fmod(v->azimuth - (float)dx * 0.3f, 360.0f);
        v->elevation = std::min(89.0f, std::max(-89.0f, v->elevation + (float)dy * 0.3f));
        v->camera_dirty = true;
    } else if (v->dragging_right && dy != 0) {
        v->distance = std::min(20.0f, std::max(0.05f, v->distance * std::exp((float)dy * 0.005f)));
        v->camera_dirty = true;
    }
}

static void on_scroll(GLFWwindow *w, double dx, double dy)
{
    (void)dx;
    viewer *v = of(w);
    v->distance = std::min(20.0f, std::max(0.05f, v->distance * std::pow(0.9f, (float)dy)));
    v->camera_dirty = true;
}

static void on_refresh(GLFWwindow *w) { of(w)->refresh = true; }

static void on_resize(GLFWwindow *w, int width, int height)
{
    (void)width;
    (void)height;
    of(w)->resized = true;
}

static size_t count_names(const char *(*name)(size_t))
{
    size_t n = 0;
    while (name(n)) n++;
    return n;
}

static size_t cycle(size_t index, int step, size_t n)
{
    long i = ((long)index + step) % (long)n;
    return (size_t)(i < 0 ? i + (long)n : i);
}

/* Applies the keys pressed since the last frame.  false: an error (already reported). */
static bool apply_keys(viewer &v)
{
    bool changed = false;
    if (v.key_cache % 2 && v.opt.render == PICVR_RENDER_MC) {  /* a context of the other mode on the same device; the scene as it is */
        picvr_cache_mode next = v.cache == PICVR_CACHE_NONE ? PICVR_CACHE_OBJECT_SPACE : PICVR_CACHE_NONE;
        picvr_destroy(v.ctx);
        v.ctx = nullptr;
        if (next == PICVR_CACHE_NONE) v.view = PICVR_VIEW_IMAGE;
        if (!create_context(v, next)) return false;
        fprintf(stderr, PROGRAM ": cache %s%s\n", next == PICVR_CACHE_NONE ? "off" : "on (object-space locking)",
                next != PICVR_CACHE_NONE ? "; it serves single isotropic scattering only (a cloud with bounces "
                                           "or g != 0 renders by plain Monte Carlo)" : "");
        changed = true;
    }
    if (v.key_view) {
        if (v.cache == PICVR_CACHE_NONE) {
            fprintf(stderr, PROGRAM ": the debug views need the cache: press C first\n");
        } else {
            v.view = (picvr_debug_view)((v.view + v.key_view) % 3);
            if (!check(picvr_set_view(v.ctx, v.view), "picvr_set_view")) return false;
            changed = true;
        }
    }
    if (v.key_tf) {
        v.tf_index = cycle(v.tf_index, v.key_tf, count_names(pvp_tf_name));
        if (!set_transfer_function(v)) return false;
        fprintf(stderr, PROGRAM ": transfer function %s\n", pvp_tf_name(v.tf_index));
        changed = true;
    }
    if (v.key_lights) {
        v.lights_index = cycle(v.lights_index, v.key_lights, count_names(pvp_lights_name));
        if (!build_lights(v) || !set_lights(v)) return false;
        fprintf(stderr, PROGRAM ": lights %s\n", pvp_lights_name(v.lights_index));
        changed = true;
    }
    if (v.key_reset) {
        if (!check(picvr_reset(v.ctx), "picvr_reset")) return false;
        changed = true;
    }
    v.key_cache = v.key_view = v.key_tf = v.key_lights = v.key_reset = 0;
    if (changed) v.idle = false;
    return true;
}

/* ---- frames -------------------------------------------------------------------------------- */

static const char *view_name(picvr_debug_view view)
{
    return view == PICVR_VIEW_CACHE ? "cache" : view == PICVR_VIEW_CACHE_ERROR ? "cache error" : "image";
}

static void update_title(viewer &v, double fps)
{
    char title[512], error[32] = "-";  /* Eq. 5 needs two samples in a pixel */
    if (v.stats.iterations_mean > 1.0) snprintf(error, sizeof error, "%.1f %%", 100.0 * v.stats.est_rel_error);
    snprintf(title, sizeof title, PROGRAM " - %.1f fps - %.1f spp - est. error %s - %s, %s - cache %s%s%s - %s",
             fps, v.stats.iterations_mean, error, pvp_tf_name(v.tf_index),
             pvp_lights_name(v.lights_index), v.cache == PICVR_CACHE_NONE ? "off" : "on",
             v.view != PICVR_VIEW_IMAGE ? " - view " : "", v.view != PICVR_VIEW_IMAGE ? view_name(v.view) : "",
             v.idle ? "done" : "refining");
    glfwSetWindowTitle(v.window, title);
}

/* picvr_step, split: the window's events keep flowing while the device renders (the
   callbacks only take note; what they ask for is applied between frames). */
static bool step(viewer &v, double budget)
{
    if (!check(picvr_step_begin(v.ctx, budget), "picvr_step_begin")) return false;
    for (;;) {
        picvr_status s = picvr_step_end(v.ctx, 2000000);  /* 2 ms */
        if (s == PICVR_OK) return true;
        if (s != PICVR_ERROR_TIMEOUT) return check(s, "picvr_step_end");
        glfwPollEvents();
    }
}

/* Renders one frame into the next swapchain image and presents it (render: false shows
   the image as it is).  0: presented; 1: skipped (the swapchain was out of date and is
   recreated); -1: an error. */
static int frame(viewer &v, bool render, bool screenshot)
{
    double t0 = pvc_now_ms();
    /* The frame's budget: frame_ms less what the rest of a frame took lately. */
    double budget = std::max(0.25 * v.opt.frame_ms, v.opt.frame_ms - v.other_ms);
    if (render && !step(v, budget)) return -1;
    double t1 = pvc_now_ms();
    if (v.opt.frames) {  /* tests: the contract of scheduler.frames, checked every frame */
        if (!check(picvr_get_stats(v.ctx, &v.stats), "picvr_get_stats")) return -1;
        if (v.stats.pixels_unsampled) {
            v.holes_frames++;
            fprintf(stderr, PROGRAM ": frame %u: %llu pixels hold no sample\n", v.frames_done,
                    (unsigned long long)v.stats.pixels_unsampled);
        }
    }
    uint32_t index = 0;
    VkResult r = vkAcquireNextImageKHR(v.device, v.swapchain, UINT64_MAX, v.acquired, VK_NULL_HANDLE, &index);
    if (r == VK_ERROR_OUT_OF_DATE_KHR) {
        v.swapchain_stale = true;
        return 1;
    }
    if (r == VK_SUBOPTIMAL_KHR) v.swapchain_stale = true;  /* present this one, then recreate */
    else if (!vk_ok(r, "vkAcquireNextImageKHR")) return -1;

    /* The image, tone-mapped, straight into the swapchain image: no host copy. */
    picvr_image_target t = {};
    t.image = v.images[index];
    t.width = v.extent.width;
    t.height = v.extent.height;
    t.format = (uint32_t)v.surface_format.format;
    t.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;  /* every pixel is written */
    t.new_layout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    t.wait_semaphore = v.acquired;
    t.signal_semaphore = v.render_done[index];
    t.exposure = v.opt.exposure;
    if (!check(picvr_write_image(v.ctx, &t), "picvr_write_image")) return -1;

    VkSemaphore present_wait = v.render_done[index];
    if (screenshot) {
        const char *path = v.opt.screenshot ? v.opt.screenshot : PROGRAM ".png";
        bool ok;
        if (v.swapchain_readable) {  /* what is shown: the swapchain image itself */
            ok = save_image(v, v.images[index], v.surface_format.format, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                            v.render_done[index], v.shot_done, path);
            present_wait = v.shot_done;
        } else {
            ok = save_own_image(v, path);
        }
        if (!ok) return -1;
        fprintf(stderr, PROGRAM ": wrote %s (%ux%u, %s)\n", path, v.extent.width, v.extent.height,
                v.swapchain_readable ? "the swapchain image" : "a second picvr_write_image");
    }
    VkPresentInfoKHR pi = {};
    pi.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
    pi.waitSemaphoreCount = 1;
    pi.pWaitSemaphores = &present_wait;
    pi.swapchainCount = 1;
    pi.pSwapchains = &v.swapchain;
    pi.pImageIndices = &index;
    r = vkQueuePresentKHR(v.queue, &pi);
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) v.swapchain_stale = true;
    else if (!vk_ok(r, "vkQueuePresentKHR")) return -1;

    double t2 = pvc_now_ms(), ms = t2 - t0;
    v.other_ms = v.frames_done ? 0.9 * v.other_ms + 0.1 * (t2 - t1) : t2 - t1;
    if (v.frames_done == 0) v.first_frame_ms = ms;
    v.frame_ms_sum += ms;
    v.step_ms_sum += t1 - t0;
    v.frame_ms_max = std::max(v.frame_ms_max, ms);
    v.frames_done++;
    return 0;
}

/* The interactive loop, or --frames N. */
static bool run(viewer &v)
{
    double title_ms = pvc_now_ms();
    uint32_t title_frames = 0;
    while (!glfwWindowShouldClose(v.window)) {
        if (v.idle || !v.swapchain) glfwWaitEventsTimeout(0.25);  /* nothing to refine or show */
        else glfwPollEvents();
        if (!apply_keys(v)) return false;
        if (v.resized || v.swapchain_stale) {
            v.resized = false;
            VkExtent2D before = v.extent;
            if (!create_swapchain(v)) return false;
            if (v.swapchain && (v.extent.width != before.width || v.extent.height != before.height))
                v.camera_dirty = true;
            v.idle = false;
        }
        if (!v.swapchain) continue;  /* minimized */
        if (v.opt.orbit != 0.0f && v.frames_done > 0 && !v.dragging_left) {  /* the turntable */
            v.azimuth = std::fmod(v.azimuth + v.opt.orbit, 360.0f);
            v.camera_dirty = true;
        }
        if (v.camera_dirty) {
            if (!set_camera(v)) return false;
            v.idle = false;
        }
        bool shot = v.key_shot > 0 || (v.opt.frames && v.frames_done + 1 == v.opt.frames && v.opt.screenshot);
        if (v.idle && !shot && !v.refresh) continue;
        int f = frame(v, !v.idle, shot);
        if (f < 0) return false;
        if (f == 0) {
            v.key_shot = shot ? 0 : v.key_shot;
            v.refresh = false;
            title_frames++;
        }
        if (v.opt.frames && v.frames_done >= v.opt.frames) break;
        double now = pvc_now_ms();
        if (now - title_ms >= 500.0 && (title_frames || !v.idle)) {
            if (!check(picvr_get_stats(v.ctx, &v.stats), "picvr_get_stats")) return false;
            if (v.stats.iterations_mean >= v.opt.max_spp) v.idle = true;
            update_title(v, 1e3 * title_frames / (now - title_ms));
            title_ms = now;
            title_frames = 0;
        }
    }
    return true;
}

/* ---- set-up and main --------------------------------------------------------------------- */

static bool load_files(viewer &v)
{
    char err[8192];
    picvr_io_layout layout;
    const char *path = v.opt.volume_path;   /* NRRD, NIfTI, VDB, DICOM: the header gives the layout */
    const bool nrrd = picvr_io_is_nrrd(path) || picvr_io_is_nifti(path) || picvr_io_is_vdb(path) || picvr_io_is_dicom(path);
    if (nrrd && (v.opt.have_dims || v.opt.have_type)) {
        pvc_fail("%s: --dims and --type come from the file's header", v.opt.volume_path);
        return false;
    }
    if (!nrrd && !(v.opt.have_dims && v.opt.have_type) &&
        picvr_io_parse_name(v.opt.volume_path, &layout, err, sizeof err) != PICVR_IO_OK) {
        pvc_fail("%s", err);
        return false;
    }
    if (v.opt.have_dims) memcpy(layout.dims, v.opt.dims, sizeof layout.dims);
    if (v.opt.have_type) layout.type = v.opt.type;
    if (picvr_io_load(v.opt.volume_path, nrrd ? nullptr : &layout, &v.volume, err, sizeof err) != PICVR_IO_OK) {
        pvc_fail("%s", err);
        return false;
    }
    if (v.opt.have_spacing) memcpy(v.volume.spacing, v.opt.spacing, sizeof v.volume.spacing);
    if (v.opt.env_path) {
        pvenv_status s = pvenv_load_hdr(v.opt.env_path, &v.env_rgb, &v.env_width, &v.env_height, err, sizeof err);
        if (s != PVENV_OK) {
            pvc_fail("--env %s", err);
            return false;
        }
    }
    return true;
}

static void on_glfw_error(int code, const char *message)
{
    fprintf(stderr, PROGRAM ": glfw error %d: %s\n", code, message);
}

static bool set_up(viewer &v)
{
    if (!load_files(v)) return false;
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit()) {
        pvc_fail("cannot open a window (no display? run it under xvfb-run for tests)");
        return false;
    }
    if (!glfwVulkanSupported()) {
        pvc_fail("GLFW finds no Vulkan loader");
        return false;
    }
    if (!create_instance(v) || !create_device(v)) return false;
    bool cpu = v.props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    uint32_t w = v.opt.have_size ? v.opt.width : cpu ? 512 : 1280, h = v.opt.have_size ? v.opt.height : cpu ? 384 : 720;
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    v.window = glfwCreateWindow((int)w, (int)h, PROGRAM, nullptr, nullptr);
    if (!v.window) {
        pvc_fail("glfwCreateWindow failed");
        return false;
    }
    glfwSetWindowUserPointer(v.window, &v);
    glfwSetKeyCallback(v.window, on_key);
    glfwSetMouseButtonCallback(v.window, on_button);
    glfwSetCursorPosCallback(v.window, on_cursor);
    glfwSetScrollCallback(v.window, on_scroll);
    glfwSetFramebufferSizeCallback(v.window, on_resize);
    glfwSetWindowRefreshCallback(v.window, on_refresh);
    if (!vk_ok(glfwCreateWindowSurface(v.instance, v.window, nullptr, &v.surface), "glfwCreateWindowSurface"))
        return false;
    VkBool32 present = VK_FALSE;
    vkGetPhysicalDeviceSurfaceSupportKHR(v.phys, v.family, v.surface, &present);
    if (!present) {
        pvc_fail("queue family %u of %s cannot present to the window", v.family, v.props.deviceName);
        return false;
    }
    if (!pick_surface_format(v) || !create_swapchain(v)) return false;
    if (!v.swapchain) v.extent = {w, h};  /* started minimized: the camera needs a size */

    v.azimuth = v.opt.azimuth;
    v.elevation = v.opt.elevation;
    v.distance = v.opt.distance;
    const char *tf_name = v.opt.tf_name ? v.opt.tf_name : default_tf(v);
    for (size_t i = 0; pvp_tf_name(i); i++)
        if (!strcmp(pvp_tf_name(i), tf_name)) v.tf_index = i;
    for (size_t i = 0; pvp_lights_name(i); i++)
        if (!strcmp(pvp_lights_name(i), v.opt.lights_name)) v.lights_index = i;
    if (!create_context(v, v.opt.cache)) return false;
    fprintf(stderr, PROGRAM ": %s (%s), %ux%u %s swapchain%s; press H for the keys\n", v.props.deviceName,
            cpu ? "cpu" : "gpu", v.extent.width, v.extent.height,
            v.surface_format.format == VK_FORMAT_B8G8R8A8_UNORM   ? "B8G8R8A8_UNORM"
            : v.surface_format.format == VK_FORMAT_R8G8B8A8_UNORM ? "R8G8B8A8_UNORM"
            : v.surface_format.format == VK_FORMAT_B8G8R8A8_SRGB  ? "B8G8R8A8_SRGB"
                                                                  : "R8G8B8A8_SRGB",
            v.validation ? ", validation layer on" : "");
    return true;
}

static void tear_down(viewer &v)
{
    if (v.device) vkDeviceWaitIdle(v.device);
    picvr_destroy(v.ctx);  /* before the device it uses */
    if (v.device) {
        destroy_swapchain_objects(v);
        vkDestroySwapchainKHR(v.device, v.swapchain, nullptr);
        vkDestroySemaphore(v.device, v.acquired, nullptr);
        vkDestroySemaphore(v.device, v.shot_done, nullptr);
        vkDestroyFence(v.device, v.fence, nullptr);
        vkDestroyCommandPool(v.device, v.pool, nullptr);
        vkDestroyDevice(v.device, nullptr);
    }
    if (v.instance) {
        vkDestroySurfaceKHR(v.instance, v.surface, nullptr);
        auto destroy = (PFN_vkDestroyDebugUtilsMessengerEXT)vkGetInstanceProcAddr(v.instance, "vkDestroyDebugUtilsMessengerEXT");
        if (destroy && v.messenger) destroy(v.instance, v.messenger, nullptr);
        vkDestroyInstance(v.instance, nullptr);
    }
    if (v.window) glfwDestroyWindow(v.window);
    glfwTerminate();
    picvr_io_free(&v.volume);
    pvenv_free(v.env_rgb);
}

int main(int argc, char **argv)
{
    pvc_set_program(PROGRAM);
    viewer *v = new viewer();
    int status = parse_options(argc, argv, &v->opt);
    if (status >= 0) {
        delete v;
        return status;
    }
    bool ok = set_up(*v) && run(*v);
    if (ok && v->ctx) ok = check(picvr_get_stats(v->ctx, &v->stats), "picvr_get_stats");
    if (v->ctx && v->frames_done) {
        const picvr_stats &s = v->stats;
        /* One line for the tests (tools/check_viewer.sh reads it), key=value. */
        printf(PROGRAM ": frames=%u size=%ux%u spp_mean=%.3f spp_min=%u est_rel_error=%.5g mean_luminance=%.5g "
               "frame_ms_mean=%.2f step_ms_mean=%.2f frame_ms_max=%.2f first_frame_ms=%.1f frames_with_holes=%u "
               "validation=%u picvr_validation=%u device=\"%s\"\n",
               v->frames_done, v->extent.width, v->extent.height, s.iterations_mean, s.iterations_min,
               s.est_rel_error, s.mean_luminance, v->frame_ms_sum / v->frames_done, v->step_ms_sum / v->frames_done, v->frame_ms_max,
               v->first_frame_ms, v->holes_frames, v->validation_messages, s.validation_messages,
               v->props.deviceName);
    }
    tear_down(*v);
    /* counted after tear-down: the layer also reports leaks at vkDestroyDevice */
    uint32_t messages = v->validation_messages + v->stats.validation_messages;
    if (v->opt.frames && ok && (messages || v->holes_frames || v->frames_done < v->opt.frames)) {
        if (messages) fprintf(stderr, PROGRAM ": %u validation messages\n", messages);
        if (v->holes_frames) fprintf(stderr, PROGRAM ": %u frames with unsampled pixels\n", v->holes_frames);
        if (v->frames_done < v->opt.frames)
            fprintf(stderr, PROGRAM ": %u of %u frames rendered\n", v->frames_done, v->opt.frames);
        ok = false;
    }
    delete v;
    return ok ? EXIT_SUCCESS : EXIT_FAILURE;
}
