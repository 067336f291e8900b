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
# The charts of `blockdem verify` draw their text with DejaVu Sans (plotters + ab_glyph).
if [ ! -f /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf ] && command -v apt-get >/dev/null 2>&1; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq && $SUDO apt-get install -y -qq fonts-dejavu-core >/dev/null || echo "blockdem: fonts-dejavu-core not installed; verify charts will be skipped" >&2
fi
