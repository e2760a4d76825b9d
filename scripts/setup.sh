#!/usr/bin/env bash
# Installs what vsl-studio needs on Debian 12, and nothing else. Idempotent:
# when everything is present it only checks (well under a second).
#   - Debian packages (apt-get; sudo when not root)
#   - the Khronos glTF validator from npm, into .tools/ (used by the tests)
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake pkg-config git python3
  libembree-dev libtbb-dev libtinygltf-dev libopenexr-dev openexr libstb-dev
  libnanoflann-dev libcli11-dev nlohmann-json3-dev libpng-dev
  libglfw3-dev libimgui-dev libegl-dev libegl1-mesa-dev libgl-dev libosmesa6-dev
  libgtest-dev libbenchmark-dev xvfb xauth gnuplot-nox
)
# scripts/fuzz.sh: clang and its libFuzzer runtime (only with --fuzz).
# scripts/measure-studio-latency.sh: drives the studio and takes screenshots
# (only with --measure).
for arg in "$@"; do
  case $arg in
    --fuzz) PACKAGES+=(clang-14 libclang-rt-14-dev) ;;
    --measure) PACKAGES+=(xdotool imagemagick openbox) ;;
    *) echo "setup: unknown option '$arg' (--fuzz, --measure)" >&2; exit 2 ;;
  esac
done
command -v node >/dev/null 2>&1 || PACKAGES+=(nodejs)
command -v npm >/dev/null 2>&1 || PACKAGES+=(npm)

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
# The packages among "$@" that are not installed, one per line.
missing_of() {
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}
apt_install() {
  $SUDO apt-get update -qq &&
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

mapfile -t missing < <(missing_of "${PACKAGES[@]}")
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} Debian package(s): ${missing[*]}"
  apt_install "${missing[@]}"
fi

# The decoders of compressed glTF meshes (EXT_meshopt_compression,
# KHR_draco_mesh_compression; docs/REFERENCE.md, "Loading: compressed
# meshes"). Optional: without them the build still works and the loader
# refuses such files naming the package, so a machine that cannot install
# them only warns here.
mapfile -t optional_missing < <(missing_of libmeshoptimizer-dev libdraco-dev)
if [ ${#optional_missing[@]} -gt 0 ]; then
  echo "setup: installing ${#optional_missing[@]} optional Debian package(s): ${optional_missing[*]}"
  apt_install "${optional_missing[@]}" ||
    echo "setup: warning: could not install ${optional_missing[*]}: compressed glTF meshes will be refused" >&2
fi

VALIDATOR_VERSION=2.0.0-dev.3.10
if [ ! -f .tools/node_modules/gltf-validator/package.json ] ||
   ! grep -q "\"version\": \"$VALIDATOR_VERSION\"" .tools/node_modules/gltf-validator/package.json; then
  echo "setup: installing gltf-validator $VALIDATOR_VERSION into .tools/"
  mkdir -p .tools
  npm install --prefix .tools --no-audit --no-fund --loglevel=error "gltf-validator@$VALIDATOR_VERSION" >/dev/null
fi
echo "setup: all dependencies present"
