# Sourced by the scripts: makes sure a Rust toolchain able to build the crate is present.
if ! command -v cargo >/dev/null 2>&1; then
  if [ -x "$HOME/.cargo/bin/cargo" ]; then
    export PATH="$HOME/.cargo/bin:$PATH"
  else
    echo "blockdem: installing a Rust toolchain (rustup, from Debian's archive)" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq rustup build-essential pkg-config >/dev/null
    rustup default stable
  fi
fi

# Off-screen GPU adapters that work without a GPU (Mesa): Vulkan through lavapipe and GL through
# EGL/llvmpipe, so the GPU backend and its tests run anywhere; and DejaVu Sans, the font the charts
# of `blockdem verify` and `blockdem bench` draw their text with. Installed only when missing.
BLOCKDEM_GPU_PACKAGES="mesa-vulkan-drivers libvulkan1 libegl1 libegl-mesa0 libgl1-mesa-dri fonts-dejavu-core"
blockdem_missing=""
for p in $BLOCKDEM_GPU_PACKAGES; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || blockdem_missing="$blockdem_missing $p"
done
if [ -n "$blockdem_missing" ] && command -v apt-get >/dev/null 2>&1; then
  echo "blockdem: installing the software GPU adapters and chart font:$blockdem_missing" >&2
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq $blockdem_missing >/dev/null
fi
unset blockdem_missing
# Headless Mesa: EGL's surfaceless platform, and no device-select layer (it probes for a Wayland
# display and prints "XDG_RUNTIME_DIR is invalid" on every Vulkan instance).
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
  export EGL_PLATFORM="${EGL_PLATFORM:-surfaceless}"
  export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
fi
