#!/bin/sh
# check_examples.sh BUILD_DIR LIB - compiles and runs the two examples a user copies
# first: the EXAMPLE at the top of picvr.h and the C block under "Using the library" in
# README.md.  Each is cut out of its document as written, wrapped in a main() that
# supplies what the text leaves to the reader (the voxels: a ball; the pixel buffer),
# compiled as C11 and as C++17 with -Wall -Wextra -Wpedantic -Wshadow -Werror and run
# with the validation layer on.  It fails if
# an example does not compile against the current API, does not return 0, renders no
# iteration, gives a non-finite error estimate, or draws a validation message.
set -eu
B=$1
LIB=$2
CC=${CC:-cc}
CXX=${CXX:-c++}
mkdir -p "$B/examples-check"
D=$B/examples-check

# The header's example: the comment lines between " * EXAMPLE" and the next rule,
# without the comment prefix.
awk '/^ \* EXAMPLE/ { on = 1; next } on && /^ \* -----/ { exit } on' picvr.h |
    sed -e 's/^ \*    //' -e 's/^ \*$//' > "$D/header_example.inc"
# The README's example: the first ```c block.
awk '/^```c$/ { on = 1; next } on && /^```$/ { exit } on' README.md |
    grep -v '^#include' > "$D/readme_example.inc"

for name in header_example readme_example; do
    if [ ! -s "$D/$name.inc" ]; then echo "check_examples: $name not found" >&2; exit 1; fi
    cat > "$D/$name.c" <<WRAP
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "picvr.h"

static uint8_t voxels[256 * 256 * 256];   /* the data the example uploads */
static uint8_t pixels[512 * 512 * 4];     /* the README example's output */

int main(void) {
    for (int z = 0; z < 256; z++)         /* a soft ball of radius 100 voxels */
        for (int y = 0; y < 256; y++)
            for (int x = 0; x < 256; x++) {
                double r = sqrt((x - 127.5) * (x - 127.5) + (y - 127.5) * (y - 127.5) +
                                (z - 127.5) * (z - 127.5));
                double v = r < 100.0 ? 1.0 - r / 100.0 : 0.0;
                voxels[x + 256 * (y + 256 * z)] = (uint8_t)(255.0 * v);
            }
    (void)pixels;
#include "$name.inc"
    fprintf(stderr, "$name: %u iterations, est_rel_error %g, %u validation messages, device %s\n",
            st.iterations, st.est_rel_error, st.validation_messages, st.device_name);
    return st.iterations_mean > 0 && isfinite(st.est_rel_error) && st.validation_messages == 0 ? 0 : 1;
}
WRAP
    $CC -O2 -std=c11 -Wall -Wextra -Wpedantic -Wshadow -Werror -I. -I"$D" \
        -o "$D/$name" "$D/$name.c" "$LIB" -lvulkan -lm
    PICVR_VALIDATION=1 "$D/$name" > "$D/$name.out"
    # The same text as C++17.  `= {0}` zeroes a picvr struct in C++ too (no picvr struct
    # starts with an enum), but g++ and clang++ flag it under -Wextra; C++ code may write
    # `= {}` instead.
    cp "$D/$name.c" "$D/$name.cpp"
    $CXX -O2 -std=c++17 -Wall -Wextra -Wpedantic -Wshadow -Wno-missing-field-initializers -Werror \
        -I. -I"$D" -o "$D/$name-cpp" "$D/$name.cpp" "$LIB" -lvulkan -lm
    PICVR_VALIDATION=1 "$D/$name-cpp" > "$D/$name-cpp.out"
done
# The README's engine example (the first ```cpp block): it needs a window and a swapchain
# (examples/viewer.cpp runs it for real, tools/check_viewer.sh tests that), so here it is
# compiled only, against the current API, with the engine's objects as parameters.
awk '/^```cpp$/ { on = 1; next } on && /^```$/ { exit } on' README.md |
    grep -v -e '^#include' -e '^#define PICVR_IMPLEMENTATION' > "$D/readme_engine.inc"
if [ ! -s "$D/readme_engine.inc" ]; then echo "check_examples: readme_engine not found" >&2; exit 1; fi
cat > "$D/readme_engine.cpp" <<WRAP
#include <vulkan/vulkan.h>
#include "picvr.h"
void engine_work();
void present(VkSemaphore rendered);
int engine_example(VkInstance instance, VkPhysicalDevice physical_device, VkDevice device, VkQueue queue,
                   uint32_t queue_family, const picvr_volume_desc &cloud, const picvr_tf_point *tf,
                   uint32_t tf_count, const picvr_light &sun, const picvr_background &sky,
                   const picvr_camera &camera, VkImage swapchain_image, uint32_t width, uint32_t height,
                   VkSemaphore acquired, VkSemaphore rendered) {
#include "readme_engine.inc"
}
WRAP
$CXX -std=c++17 -fsyntax-only -Wall -Wextra -Wpedantic -Wshadow -Werror -I. -I"$D" "$D/readme_engine.cpp"
echo "check_examples: the header's and the README's examples compile and run, as C and as C++; the README's engine example compiles"
