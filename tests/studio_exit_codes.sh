#!/usr/bin/env bash
# The headless studio fails loudly and at once: exit status 1 with the reason
# for a missing scene, a scene without emitters, an export before any picture
# (--after 0) and an export into a folder that cannot be created. Then what
# succeeds headlessly: --crop puts crop insets into the export, and the last
# session (scene and settings) comes back on a start without a scene.
#   studio_exit_codes.sh VSL_STUDIO OUT_DIR
set -uo pipefail
studio=$1 out=$2
scenes="$(cd "$(dirname "$0")/../assets/scenes" && pwd)"
mkdir -p "$out"
fail=0
# A last session of our own, never the user's.
export XDG_CONFIG_HOME="$out/config"
rm -rf "$XDG_CONFIG_HOME"
session="$XDG_CONFIG_HOME/vsl-studio/last-session.json"
expect_exit1() {  # name, expected text, arguments...
  local name=$1 want=$2; shift 2
  local start=$SECONDS
  timeout 120 "$studio" --headless --window 320x240 --lights 50 --width 16 "$@" >"$out/$name.log" 2>&1
  local rc=$? took=$((SECONDS - start))
  if [ $rc -ne 1 ]; then echo "$name: exit status $rc, want 1"; fail=1; fi
  if ! grep -q "$want" "$out/$name.log"; then echo "$name: no '$want' in:"; cat "$out/$name.log"; fail=1; fi
  if [ $took -gt 60 ]; then echo "$name: took $took s"; fail=1; fi
  echo "$name: exit $rc after ${took}s"
}
printf '%s' '{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],"bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}' >"$out/dark.gltf"
: >"$out/empty.gltf"
expect_exit1 missing "cannot be read" "$out/does-not-exist.gltf" --export "$out/x"
expect_exit1 missing-no-export "cannot be read" "$out/does-not-exist.gltf"
expect_exit1 empty "error:" "$out/empty.gltf" --export "$out/x"
expect_exit1 no-emitters "no emitters" "$out/dark.gltf" --export "$out/x"
expect_exit1 after-zero "nothing to export" --export "$out/x" --after 0
touch "$out/a-file"
expect_exit1 export-unwritable "cannot create" --export "$out/a-file/sub"
expect_exit1 crop-outside "lies outside the 16x" --export "$out/x" --crop 100,100,4,4
timeout 60 "$studio" --headless --crop 1,2,3 >"$out/crop-syntax.log" 2>&1
rc=$?
if [ $rc -ne 2 ] || ! grep -q "X,Y,W,H" "$out/crop-syntax.log"; then echo "crop-syntax: exit $rc, want 2"; fail=1; fi

# Runs that succeed: exit status 0, the export's metrics.json in $out/<name>/*/.
expect_ok() {  # name, expected text on stderr, arguments...
  local name=$1 want=$2; shift 2
  rm -rf "${out:?}/$name"
  timeout 300 "$studio" --headless --window 320x240 --export "$out/$name" "$@" >"$out/$name.log" 2>&1
  local rc=$?
  if [ $rc -ne 0 ]; then echo "$name: exit status $rc, want 0"; cat "$out/$name.log"; fail=1; fi
  if ! grep -q "$want" "$out/$name.log"; then echo "$name: no '$want' in:"; cat "$out/$name.log"; fail=1; fi
  echo "$name: exit $rc"
}
json_of() { ls "$out/$1"/*/metrics.json 2>/dev/null | head -1; }
# Prints the value at a path of keys in a JSON file.
json_get() { python3 -c 'import json,sys; v=json.load(open(sys.argv[1]))
for k in sys.argv[2:]: v=v[k]
print(v)' "$@"; }
# Width and height of a PNG from its IHDR chunk.
png_size() { python3 -c 'import struct,sys; d=open(sys.argv[1],"rb").read(24); print("%dx%d" % struct.unpack(">II", d[16:24]))' "$1"; }
check_eq() {  # what, got, want
  if [ "$2" != "$3" ]; then echo "$1: got '$2', want '$3'"; fail=1; fi
}

# 1. --crop: a crop of 8x6 pixels at (2,3) is exported magnified 256/8 = 32x,
#    with the figure and the crop's metrics in the JSON. The run is saved as the
#    last session (furnace, 60 lights, width 16).
expect_ok crop "wrote .*crop-figure-indirect.png" "$scenes/furnace.gltf" --lights 60 --width 16 --crop 2,3,8,6
j=$(json_of crop)
if [ -n "$j" ]; then
  d=$(dirname "$j")
  check_eq "crop rectangle" "$(json_get "$j" crop x),$(json_get "$j" crop y),$(json_get "$j" crop width),$(json_get "$j" crop height)" "2,3,8,6"
  check_eq "crop magnification" "$(json_get "$j" crop magnification)" 32
  for f in crop-reference-indirect crop-vsl-indirect crop-vpl-clamped-indirect crop-error-vsl-relabs-indirect; do
    if [ -f "$d/$f.png" ]; then check_eq "$f.png size" "$(png_size "$d/$f.png")" 256x192; else echo "no $f.png"; fail=1; fi
  done
  json_get "$j" crop metricsAgainstReferenceCrop VSL indirect relMSE >/dev/null || fail=1
fi
if [ -f "$session" ]; then
  check_eq "saved scene" "$(json_get "$session" scene)" "$scenes/furnace.gltf"
  check_eq "saved lights" "$(json_get "$session" settings lights)" 60
else
  echo "no last session saved at $session"; fail=1
fi

# 2. No scene argument: the last session's scene and light count come back.
expect_ok restored "restored the last session" --width 16
j=$(json_of restored)
[ -n "$j" ] && check_eq "restored scene" "$(json_get "$j" scene)" "$scenes/furnace.gltf"
[ -n "$j" ] && check_eq "restored lights" "$(json_get "$j" settings lights)" 60

# 3. --fresh ignores it: the default scene.
expect_ok fresh "exported to" --fresh --lights 40 --width 16
j=$(json_of fresh)
[ -n "$j" ] && check_eq "fresh scene" "$(basename "$(json_get "$j" scene)")" cornell-glossy.gltf

# 4. The saved scene no longer exists: the default scene, with a message.
cp "$scenes/furnace.gltf" "$out/gone.gltf"
expect_ok gone-save "exported to" "$out/gone.gltf" --lights 30 --width 16
rm -f "$out/gone.gltf"
expect_ok gone "no longer exists" --width 16
j=$(json_of gone)
[ -n "$j" ] && check_eq "scene after a missing one" "$(basename "$(json_get "$j" scene)")" cornell-glossy.gltf
[ -n "$j" ] && check_eq "lights after a missing scene" "$(json_get "$j" settings lights)" 30

# 5. A corrupt file: a warning and the defaults, never a crash.
printf '{"scene": "%s", "settings": {"lights": 7' "$scenes/furnace.gltf" >"$session"
expect_ok corrupt "starting with the defaults" --lights 40 --width 16
j=$(json_of corrupt)
[ -n "$j" ] && check_eq "scene after a corrupt file" "$(basename "$(json_get "$j" scene)")" cornell-glossy.gltf

exit $fail
