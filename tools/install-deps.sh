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
# The file readers of picvr_io (NIfTI, DICOM, OpenVDB; OpenVDB's headers need boost) and
# picvr-render's OpenEXR output; real scans the tests read and the README renders: a T1
# MRI head (mricron-data's ch2.nii.gz), nibabel's NIfTI and pydicom's DICOM test files.
PKGS="gcc g++ clang make pkg-config mesa-vulkan-drivers libvulkan-dev glslang-tools \
vulkan-validationlayers vulkan-tools libstb-dev libcmocka-dev zlib1g-dev \
libnifti2-dev libgdcm-dev libopenvdb-dev libboost-dev libopenexr-dev \
mricron-data python3-nibabel python3-pydicom$extra"
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
