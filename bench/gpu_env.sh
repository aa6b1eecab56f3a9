# bench/gpu_env.sh - sourced by gpu_check.sh and gpu_tests.sh on the device machine.
# That machine is bare: the folder EXTRA (default .gpu/extra) holds the .deb files of
# libstb0, libcmocka0 and vulkan-validationlayers, downloaded here (docs/gpu.md).  They are unpacked into /tmp/picvr-extra, not into / (which the device tool's
# notes say they could break), and the dynamic linker and the Vulkan loader are pointed
# there.  Nothing happens when EXTRA is absent (a machine with the packages installed).
# Sourced again by a script the first one runs (gpu_session.sh runs gpu_check.sh and
# gpu_tests.sh): PICVR_EXTRA, exported, says the packages are unpacked already.
EXTRA=${EXTRA:-.gpu/extra}
if [ -d "$EXTRA" ] && [ -z "${PICVR_EXTRA:-}" ]; then
    PICVR_EXTRA=/tmp/picvr-extra
    mkdir -p "$PICVR_EXTRA"
    for f in "$EXTRA"/*.deb; do dpkg -x "$f" "$PICVR_EXTRA"; done
    LD_LIBRARY_PATH="$PICVR_EXTRA/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
    VK_LAYER_PATH="$PICVR_EXTRA/usr/share/vulkan/explicit_layer.d"
    export LD_LIBRARY_PATH VK_LAYER_PATH PICVR_EXTRA
fi
