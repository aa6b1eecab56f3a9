#!/bin/sh
# Installs the Debian packages picvr needs, only those that are missing.
# Uses apt-get as root, or through sudo when not root.  Safe to run repeatedly.
# g++ and clang: `make test` compiles the library with both compilers, as C and C++.
# Extra packages may be named as arguments (make bench: gnuplot-nox for the plots);
# `install-deps.sh robust` adds the tools of the robustness targets (make test-asan,
# valgrind, fuzz, soak): clang with its libFuzzer/sanitizer runtimes, and valgrind.
set -e
extra=""
for a in "$@"; do
  case "$a" in
    robust) extra="$extra clang libclang-rt-14-dev valgrind" ;;
    viewer) extra="$extra libglfw3-dev xvfb xauth" ;;
    *) extra="$extra $a" ;;
  esac
done
PKGS="gcc g++ clang make pkg-config mesa-vulkan-drivers libvulkan-dev glslang-tools \
vulkan-validationlayers vulkan-tools libstb-dev libcmocka-dev zlib1g-dev$extra"
missing=""
for p in $PKGS; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing="$missing $p"
  fi
done
[ -z "$missing" ] && exit 0
echo "install-deps: installing$missing"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
