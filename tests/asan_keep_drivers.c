/* asan_keep_drivers.c - linked only into the `make test-asan` binaries.
 *
 * The Vulkan loader dlclose()s the driver (Mesa lavapipe, with LLVM) and the
 * validation layer when the last instance is destroyed, so LeakSanitizer's report at
 * exit cannot name the module of their allocations ("<unknown module>") and no
 * suppression could tell them from ours.  Opening them once more with RTLD_NODELETE
 * (RTLD_LOCAL: no symbol becomes visible to anyone) keeps them mapped, so their frames
 * are symbolized and tests/lsan.supp can suppress exactly those modules.  Nothing else
 * changes: the loader still opens and initializes them as usual.  A module that is
 * missing is skipped. */
#define _GNU_SOURCE
#include <dlfcn.h>

__attribute__((constructor)) static void asan_keep_drivers(void) {
    static const char *const libs[] = {"libvulkan_lvp.so", "libVkLayer_khronos_validation.so",
                                       "libLLVM-15.so.1"};
    for (unsigned i = 0; i < sizeof libs / sizeof libs[0]; i++)
        (void)dlopen(libs[i], RTLD_LAZY | RTLD_LOCAL | RTLD_NODELETE);
}
