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

# A newer Mesa where the distribution's own is old. Mesa 22's lavapipe loads and stores storage
# buffers a lane at a time, a loop per field; with Mesa 25 a cycle takes ~20% less time (most
# kernels half, the contact stage 15% less; docs/BENCHMARKS.md). On Debian 12 (bookworm, Mesa 22.3) it comes from the archive's backports
# suite, added from the machine's own archive entry. BLOCKDEM_SYSTEM_MESA=1 keeps the system's.
blockdem_mesa_major() {
  dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null | sed -E 's/^([0-9]+:)?([0-9]+).*/\2/'
}
if [ -z "${BLOCKDEM_SYSTEM_MESA:-}" ] && command -v apt-get >/dev/null 2>&1 \
  && grep -qs '^VERSION_CODENAME=bookworm' /etc/os-release && [ "$(blockdem_mesa_major)" -lt 24 ] 2>/dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
    if [ -f /etc/apt/sources.list.d/debian.sources ]; then
      # deb822: the paragraph of the main suites, with the backports suite instead.
      awk 'BEGIN { RS = ""; ORS = "\n\n" } /Suites:[^\n]*bookworm( |\n|$)/ && !/security/' /etc/apt/sources.list.d/debian.sources \
        | sed 's/^Suites: .*/Suites: bookworm-backports/' | $SUDO tee /etc/apt/sources.list.d/blockdem-backports.sources >/dev/null
    elif [ -f /etc/apt/sources.list ]; then
      grep -E '^deb [^#]* bookworm main' /etc/apt/sources.list | head -n 1 | sed 's/ bookworm main/ bookworm-backports main/' \
        | $SUDO tee /etc/apt/sources.list.d/blockdem-backports.list >/dev/null
    fi
  fi
  echo "blockdem: updating Mesa's software adapters from bookworm-backports (BLOCKDEM_SYSTEM_MESA=1 keeps Mesa $(blockdem_mesa_major))" >&2
  if $SUDO apt-get update -qq && $SUDO apt-get install -y -qq -t bookworm-backports mesa-vulkan-drivers libegl-mesa0 libgl1-mesa-dri >/dev/null; then
    :
  else
    echo "blockdem: could not update Mesa; the tests run on Mesa $(blockdem_mesa_major)" >&2
  fi
fi
unset -f blockdem_mesa_major
# Headless Mesa: EGL's surfaceless platform, and no device-select layer (it probes for a Wayland
# display and prints "XDG_RUNTIME_DIR is invalid" on every Vulkan instance).
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
  export EGL_PLATFORM="${EGL_PLATFORM:-surfaceless}"
  export NODEVICE_SELECT="${NODEVICE_SELECT:-1}"
fi
