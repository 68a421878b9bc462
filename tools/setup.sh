#!/usr/bin/env bash
# Installs what Translucent needs on a Debian machine and does nothing when it is all there:
# the Vulkan loader, lavapipe (Mesa's CPU Vulkan driver), the Khronos validation layer, glslc, and
# for `translucent view` and its CI test: Xvfb (a virtual X server) and the X11 libraries winit
# loads at run time (libX11-xcb, Xcursor, Xrandr, Xi, xkbcommon-x11).
# Rust itself is expected (rustup); this script does not install a toolchain.
set -euo pipefail

# Debian package -> a file it provides that we can test for cheaply.
declare -A needs=(
  [libvulkan1]=/usr/lib/x86_64-linux-gnu/libvulkan.so.1
  [mesa-vulkan-drivers]=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
  [vulkan-validationlayers]=/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json
  [glslc]=/usr/bin/glslc
  [xvfb]=/usr/bin/Xvfb
  [libx11-xcb1]=/usr/lib/x86_64-linux-gnu/libX11-xcb.so.1
  [libxcursor1]=/usr/lib/x86_64-linux-gnu/libXcursor.so.1
  [libxrandr2]=/usr/lib/x86_64-linux-gnu/libXrandr.so.2
  [libxi6]=/usr/lib/x86_64-linux-gnu/libXi.so.6
  [libxkbcommon-x11-0]=/usr/lib/x86_64-linux-gnu/libxkbcommon-x11.so.0
)
missing=()
for pkg in "${!needs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  elif [ ! -e "${needs[$pkg]}" ] && [ "$(uname -m)" = x86_64 ]; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "setup: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
    sudo=sudo
  fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

command -v cargo >/dev/null || { echo "setup: cargo not found: install Rust with rustup (https://rustup.rs)" >&2; exit 1; }
command -v glslc >/dev/null || { echo "setup: glslc still missing after install" >&2; exit 1; }
command -v Xvfb >/dev/null || { echo "setup: Xvfb still missing after install" >&2; exit 1; }
exit 0
